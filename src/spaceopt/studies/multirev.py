"""The multi-revolution Earth-orbit studies of dissertation §4.1 built from the config.

Config: ``config/studies/multirev.yaml``, turned into a
:class:`~spaceopt.indirect.transfer.Transfer` by :mod:`.multirev_config`. This module runs chain
stages, and saves/loads the stage artifacts (JSON scalars + NPZ samples + RRD recording).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from .. import artifacts
from ..indirect import chain
from ..indirect.chain import Solution
from ..indirect.shooting import Shooting
from ..indirect.flow import Model
from ..indirect.transfer import Orbit, Transfer, datum
from ..constants import DAY
from .trajectory import sample


# ---------------------------------------------------------------- scalars and artifacts

def scalars(sol: Solution, samples: dict) -> dict:
    """Physical results of a stage (SI and days/degrees as named)."""
    tr = sol.transfer
    out = {"stage": sol.stage, "K_f_deg": math.degrees(sol.K_f), "tof_days": samples["t_s"][-1] / DAY,
           "costates": sol.costates(), "n_rev": tr.n_rev, "L0_deg": tr.L0_deg, "isp_s": tr.isp}
    if sol.stage == "lp":
        out.update(J_LP_m2s3=sol.extra["J_LP_m2s3"], dv_m_s=sol.extra["dv_m_s"],
                   T0_guess_N=chain.tmin_initial_guess(sol))
    else:
        m_f = float(samples["mass_kg"][-1])
        out.update(m_f_kg=m_f, thrust_N=sol.thrust_N, dv_m_s=tr.c * math.log(tr.m0 / m_f),
                   burn_days=(tr.m0 - m_f) * tr.c / sol.thrust_N / DAY)
        out["burn_fraction"] = out["burn_days"] / out["tof_days"]
        S = samples["S"]
        out.update(S_min=float(np.nanmin(S)), S_max=float(np.nanmax(S)))
    if sol.stage == "tmin":
        out["T_min_N"] = sol.thrust_N
        out["T0_guess_N"] = sol.extra.get("T0_N")
    return out


def save(sol: Solution, json_path, cfg: dict, wall_time_s: float, extra: dict | None = None,
         samples_per_rev: int = 200):
    """Write <stage>.json (+ .npz, .rrd) for ``sol``."""
    from ..report.recording import write_trajectory_recording

    json_path = Path(json_path)
    smp = sample(sol, samples_per_rev)
    npz = json_path.with_suffix(".npz")
    rrd = json_path.with_suffix(".rrd")
    artifacts.write_npz(npz, **smp)
    burn = smp["delta"] > 0.5
    write_trajectory_recording(rrd, smp["t_s"], smp["r_m"], burn,
                               {"mass_kg": smp["mass_kg"],
                                "thrust_N": np.linalg.norm(smp["thrust_N"], axis=1),
                                "S": smp["S"]})
    payload = {
        "scalars": scalars(sol, smp), "extra": extra or {}, "solver": sol.stats,
        "z": np.asarray(sol.z).tolist(), "unknowns": sol.shooting.unknown_names(),
        "model": {"kind": sol.shooting.model.kind, "homotopy": sol.shooting.model.homotopy,
                  "perturbed": sol.shooting.model.perturbed, "fixed_time": sol.shooting.fixed_time,
                  "free_costates": list(sol.shooting.free_costates), "switching": sol.shooting.switching,
                  **({} if sol.tau == 1.0 else {"tau": sol.tau, "thrust_pinned_N": float(sol.prm["thrust"]) * sol.transfer.force_unit})},
        "transfer": sol.transfer.as_dict(), "thrust_N": sol.thrust_N, "units": sol.transfer.units(),
        "provenance": artifacts.provenance(cfg, wall_time_s),
    }
    artifacts.write_json(json_path, payload, companions={"trajectory": npz, "recording": rrd})
    return payload


def load(json_path) -> Solution:
    """Rebuild a converged Solution from its JSON artifact (checksums verified)."""
    data = artifacts.read_json(json_path)
    t = data["transfer"]
    tr = Transfer(Orbit(**t["initial"]), Orbit(**t["final"]),
                  **{k: v for k, v in t.items() if k not in ("initial", "final")})
    m = data["model"]
    switching = m.get("switching", "smoothed")
    exact = switching == "exact"
    sh = Shooting(Model(m["kind"], m["homotopy"], m.get("perturbed", False)), tuple(m["free_costates"]),
                  fixed_time=m.get("fixed_time", False), switching=switching,
                  **{**tr.integration(), **({"path_arcs": 1} if exact else {})})
    thrust = data["thrust_N"]
    pinned = m.get("thrust_pinned_N", thrust)          # a point of a homotopy at τ < 1 (model 'tau')
    prm = tr.params(thrust=None if pinned is None or (isinstance(pinned, float) and math.isnan(pinned)) else pinned)
    if exact:                                           # as chain.to_exact leaves it
        prm["eps_final"] = datum(0.0)
    sol = Solution(data["scalars"]["stage"], sh, np.asarray(data["z"]), prm, tr, data["solver"],
                   thrust_N=thrust if thrust is not None else float("nan"), tau=m.get("tau", 1.0))
    if sol.tau != 1.0:           # an upper bound on T_min: its route's data (tmin_from_ot.bound_in_model)
        sol.extra.update(data["extra"])
    if sol.stage == "lp":
        sol.extra.update({k: data["scalars"][k] for k in ("J_LP_m2s3", "dv_m_s")})
        sol.extra["tof_s"] = data["scalars"]["tof_days"] * DAY
    return sol


def timed(fn, *args, **kwargs):
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0
