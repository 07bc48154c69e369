"""Is there a root near the end point of a failed E8 polish? The reduced function on one frame.

Where the final polish of an E8 model step fails (``<model>_n<N>.failure.json``: the single-
shooting polish's point z at τ = 1), this scans the Lyapunov–Schmidt reduced function of the
single-shooting residual f (docs/perturbed-e6-e7-e8.md, "twentieth session"):

1. chords with the SVD of J(z) bring z to its valley point x₀; a fresh Jacobian there gives the
   frame A = (u, v, U_r, V_r) (last left/right singular vectors, the rest);
2. the valley of frame A is {x : v·(x − x₀) = s, U_rᵀ f(x) = 0}, and on it g(s) = u·f(x). Its
   roots are exactly the roots of f, and it is one smooth function of s *because the frame stays
   fixed*: each point is found by Newton steps inside the slice, x ← x − V_rᵀ M⁻¹ U_rᵀ f, whose
   matrix M = U_rᵀ J V_rᵀ is refreshed from a fresh Jacobian where the steps stop contracting
   (the solver's matrix changes, the valley's definition does not). The library's march
   (``Continuation._flat_root``) holds J fixed at its origin, and a march that re-frames midway
   compares g on different curves;
3. s marches from 0 by DS, COUNT points on SIDE (+1 or −1), each start extrapolated from the
   last two points. A sign change of g brackets a root; a positive minimum says there is none
   on that stretch.

The job's shooting problem is the DAG's own (``workflow/scripts/perturbed_solve.py`` for
(model, n), up to the first multiple-shooting path, whose problem and parameters are taken and
the job stopped). One Jacobian costs ~100–150 s at 450 revolutions, a residual 10–15 s.

Run from the repository root after the DAG has written the job's start artifact:
``.venv/bin/python docs/experiments/e8_valley_scan.py g44_moon_sun 450 FAILURE_JSON -1 0.00025 6``.
"""
import json
import sys
import time
import types
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import yaml

jax.config.update("jax_enable_x64", True)
sys.path.insert(0, "workflow/scripts")
import perturbed_solve  # noqa: E402
from spaceopt.indirect import chain  # noqa: E402

T0 = time.time()


def log(msg):
    print(f"[{time.time() - T0:6.0f} s] {msg}", flush=True)


class _Captured(Exception):
    pass


def job_problem(model: str, n: float):
    """(Shooting, parameters) of the DAG's E8 job (model, n) at its multiple-shooting path."""
    got = {}

    def capture(sh, z0, prm, *args):
        got.update(sh=sh, prm=prm)
        raise _Captured

    pc = yaml.safe_load(open("config/studies/perturbed.yaml"))["perturbed"]
    cc = pc["cases"]["e8"]
    # the job's config as the DAG passes it (pt_config_for of workflow/rules/perturbed.smk,
    # which Python cannot import)
    cfg = {"constants": pc["constants"], "numerics": pc["numerics"], "models": {model: pc["models"][model]},
           "orbits": {cc[k]: pc["orbits"][cc[k]] for k in ("initial", "final")}, "cases": {"e8": cc}}
    prev = cc["models"][cc["models"].index(model) - 1]
    scratch = Path("/tmp/e8_valley_scan")
    sm = types.SimpleNamespace(
        params=types.SimpleNamespace(cfg=cfg, case="e8", model=model, n_rev=n, source=f"{prev}_n{n:g}",
                                     results="results"),
        input=types.SimpleNamespace(start=f"results/perturbed/e8/{prev}_n{n:g}.json"),
        output=[str(scratch / f"{model}_n{n:g}.{ext}") for ext in ("json", "npz", "rrd")], rule="perturbed_e8")
    original, chain._run_multiple = chain._run_multiple, capture
    try:
        perturbed_solve.main(sm)
    except _Captured:
        pass
    finally:
        chain._run_multiple = original
    return got["sh"], got["prm"]


def main(model, n, failure, side, ds, count):
    sh, prm = job_problem(model, float(n))
    side, ds, count = int(side), float(ds), int(count)

    def residual(x):
        return np.asarray(chain.residual(sh, jnp.asarray(x), 1.0, prm)[0])

    def evaluate(x):
        """(f, J) at x."""
        f, J = chain.shoot(sh, jnp.asarray(x), 1.0, prm)[:2]
        return np.asarray(f), np.asarray(J)

    z = np.asarray(json.load(open(failure))["diagnosis"]["z"])
    f, J = evaluate(z)
    U, S, Vt = np.linalg.svd(J)
    for _ in range(30):                                   # chords of J(z) to its valley point x0
        step = (U[:, :-1].T @ f) / S[:-1]
        z = z - Vt[:-1].T @ step
        if np.linalg.norm(step) < 1e-9:
            break
        f = residual(z)
    U, S, Vt = np.linalg.svd(evaluate(z)[1])
    u, v, Ur, Vr = U[:, -1], Vt[-1], U[:, :-1], Vt[:-1]
    log(f"frame A at the valley point: sigma_min {S[-1]:.3e} of {S[0]:.3e}")
    M = np.diag(S[:-1])                                   # U_rᵀ J V_rᵀ at x0, J = U diag(S) Vᵀ

    def on_valley(x, M):
        prev, fresh = np.inf, False
        for it in range(20):
            f = residual(x)
            c = Ur.T @ f
            nc = float(np.linalg.norm(c))
            if nc < min(1e-8, 0.05 * abs(u @ f)) or (fresh and nc > 0.9 * prev and it > 2):
                break
            if nc > 0.3 * prev and not fresh and it > 1 and nc > 1e-8:
                M, fresh = Ur.T @ evaluate(x)[1] @ Vr.T, True
                log(f"    fresh reduced matrix (|f_r| {nc:.2e})")
            x = x - Vr.T @ np.linalg.solve(M, c)
            prev = nc
        return x, float(u @ f), nc, M

    x, g, nc, M = on_valley(z, M)
    log(f"s {0:+.5f}: g {g:+.4e} (|f_r| {nc:.1e})")
    points = [(0.0, x)]
    for k in range(1, count + 1):
        s, (s2, x2) = side * k * ds, points[-1]
        tangent = v if len(points) == 1 else (x2 - points[-2][1]) / (s2 - points[-2][0])
        x, g, nc, M = on_valley(x2 + (s - s2) * tangent, M)
        log(f"s {s:+.5f}: g {g:+.4e} (|f_r| {nc:.1e})")
        points.append((s, x))


if __name__ == "__main__":
    main(*sys.argv[1:])
