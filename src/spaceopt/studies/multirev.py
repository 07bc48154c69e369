"""The multi-revolution Earth-orbit studies of dissertation §4.1 built from the config.

Config (``config/studies/multirev.yaml``) holds physical inputs with their units in the key
names (``*_km``, ``*_deg``, ``*_kg``, ``*_s``, ``*_N``); this module turns a case into a
:class:`~spaceopt.indirect.transfer.Transfer`, runs chain stages, and saves/loads the stage
artifacts (JSON scalars + NPZ samples + RRD recording).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from .. import artifacts
from ..elements import apsides_to_ae
from ..errors import ConfigError
from ..indirect import chain
from ..indirect.chain import Solution
from ..indirect.shooting import Shooting
from ..indirect.flow import Model
from ..indirect.transfer import Orbit, Transfer, datum
from ..constants import DAY
from .trajectory import sample

ORBIT_KEYS = ("perigee_alt_km", "apogee_alt_km", "i_deg", "raan_deg", "argp_deg")


def _number(cfg, key, path, positive=False, allow_zero=False):
    if key not in cfg:
        raise ConfigError(f"{path}.{key}", None, "missing (give the value with the unit in the key name)")
    val = cfg[key]
    if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val):
        raise ConfigError(f"{path}.{key}", val, "must be a finite number")
    if positive and not (val > 0 or (allow_zero and val == 0)):
        raise ConfigError(f"{path}.{key}", val, "must be positive")
    return float(val)


def orbit_from_config(cfg, path, radius_m) -> Orbit:
    if not isinstance(cfg, dict):
        raise ConfigError(path, cfg, "must be a mapping of orbit elements")
    unknown = sorted(set(cfg) - set(ORBIT_KEYS))
    if unknown:
        raise ConfigError(f"{path}.{unknown[0]}", cfg[unknown[0]],
                          f"unknown key (expected {', '.join(ORBIT_KEYS)}; units in the key name)")
    hp = _number(cfg, "perigee_alt_km", path) * 1e3
    ha = _number(cfg, "apogee_alt_km", path) * 1e3
    if ha < hp:
        raise ConfigError(f"{path}.apogee_alt_km", cfg["apogee_alt_km"], "apogee below perigee")
    if radius_m + hp <= 0:
        raise ConfigError(f"{path}.perigee_alt_km", cfg["perigee_alt_km"], "perigee inside the Earth's centre")
    a, e = apsides_to_ae(hp, ha, radius_m)
    return Orbit(a, e, _number(cfg, "i_deg", path), cfg.get("raan_deg", 0.0), cfg.get("argp_deg", 0.0))


def transfer_from_config(mr: dict, case: str, isp_s: float | None = None, thrust_N: float | None = None) -> Transfer:
    """Build the Transfer of ``multirev.cases.<case>`` (validating every physical input)."""
    if case not in mr.get("cases", {}):
        raise ConfigError("multirev.cases", case, "unknown case")
    cc = mr["cases"][case]
    path = f"multirev.cases.{case}"
    const = mr["constants"]
    radius = _number(const, "earth_radius_km", "multirev.constants", positive=True) * 1e3
    mu = _number(const, "mu_km3_s2", "multirev.constants", positive=True) * 1e9
    orbits = mr["orbits"]
    for end in ("initial", "final"):
        if cc.get(end) not in orbits:
            raise ConfigError(f"{path}.{end}", cc.get(end), "unknown orbit name")
    sc = mr["spacecraft"]
    n_rev = _number(cc, "n_rev", path, positive=True)
    isp = isp_s if isp_s is not None else _number(sc, "isp_s", "multirev.spacecraft", positive=True)
    return Transfer(orbit_from_config(orbits[cc["initial"]], f"multirev.orbits.{cc['initial']}", radius),
                    orbit_from_config(orbits[cc["final"]], f"multirev.orbits.{cc['final']}", radius),
                    L0_deg=_number(cc, "L0_deg", path), n_rev=n_rev,
                    m0=_number(sc, "m0_kg", "multirev.spacecraft", positive=True), isp=isp,
                    thrust=float("nan") if thrust_N is None else thrust_N, mu=mu,
                    eps_final=_number(mr["numerics"], "eps_final", "multirev.numerics", positive=True),
                    eps_blend=_number(mr["numerics"], "eps_blend", "multirev.numerics", positive=True))


def check_config(mr: dict) -> None:
    """Physical checks of the multirev section: every case to run builds a valid Transfer."""
    for i, case in enumerate(mr["run_cases"]):
        if case not in mr["cases"]:
            raise ConfigError(f"multirev.run_cases[{i}]", case, "unknown case")
        cc = mr["cases"][case]
        for isp in cc["tmin_isp_s"]:
            transfer_from_config(mr, case, isp_s=isp)
        for T in cc["ot_thrust_N"]:
            transfer_from_config(mr, case, thrust_N=T)
    t413 = mr["table_4_1_3"]
    if t413["case"] not in mr["cases"]:
        raise ConfigError("multirev.table_4_1_3.case", t413["case"], "unknown case")
    if t413["anchor_N"] not in t413["thrust_N"]:
        raise ConfigError("multirev.table_4_1_3.anchor_N", t413["anchor_N"], "must be one of thrust_N")


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
