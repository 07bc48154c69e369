"""pykep 3 side of the peer benchmark. Runs INSIDE benchmarks/.venv-pykep (see setup_pykep.sh).

For each problem of benchmarks/peer_problems.py it builds pykep's own indirect solver,
``pykep.trajopt.pontryagin_equinoctial_mass`` (single shooting in MEE, heyoka Taylor
integration, fixed time, minimum propellant), with the settings of spec 06:

- eps = 1e-5 (pykep's log-barrier smoothing, J = c1/c2 ∫ u + ε log(u(1−u)) dt), lambda0=None
  (λ0 is an unknown and |λ|² = 1 a constraint; 8 unknowns, 8 equations);
- Taylor tolerances 1e-10 (dynamics) and 1e-4 (variational, for the Jacobian);
- MINPACK hybr via scipy.optimize.root with pykep's analytic gradient, factor=1, diag = 1, tol 1e-8;
- random starts uniform in the problem's bounds (get_bounds), fixed seed.

The boundary data are set exactly: the udp is built from Cartesian states (its constructor
API), then its eq0/eqf are overwritten with the problem's MEE (p in units of L = 1 AU) and the
target longitude is fixed (n_rev >= 0: the linear constraint L(t_f) = L_f), so that pykep and
our chain solve the same problem to the last bit of the data.

A start succeeds when hybr reports success and max|F| <= --ftol (nondimensional: AU, mass
unit m0). Time to solution is the expected time to the first success = total time / successes
(spec 06). Optionally (--eps-cont) the best solution is continued in eps to smaller values
(each step one hybr solve from the previous solution) to compare with ours as eps → 0.

Usage: python peer_pykep_run.py --problems E P1 --starts 20 --seed 12345   (prints JSON)
       python peer_pykep_run.py --placeholders-only
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import math
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
TOPS_FILES = ("_tops_cr3bp.json", "_tops_twobody.json", "_tops_ss.json", "_tops_mee.json")


def ensure_placeholders() -> list[str]:
    """Work around the pykep 3.0.1 wheel: it lacks trajopt/gym/tops/*.json, which
    pykep.trajopt.gym json.load()s at import time (FileNotFoundError on `import pykep`).
    Writes '{}' (an empty JSON object, so json.load succeeds) at the missing paths inside this
    environment's installed package. The TOPS gym problems are then empty; this benchmark does
    not use them (the problem data are in peer_problems.py)."""
    spec = importlib.util.find_spec("pykep")
    if spec is None or not spec.submodule_search_locations:
        raise SystemExit("pykep is not installed in this interpreter; run benchmarks/setup_pykep.sh")
    tops = Path(list(spec.submodule_search_locations)[0]) / "trajopt" / "gym" / "tops"
    tops.mkdir(parents=True, exist_ok=True)
    made = []
    for name in TOPS_FILES:
        f = tops / name
        if not f.exists():
            f.write_text("{}\n")
            made.append(str(f))
    return made


def build_udp(pk, prob, eps, tol, tol_var):
    """pontryagin_equinoctial_mass for one problem, boundary MEE set exactly."""
    import numpy as np
    mu, L = prob["mu_m3_s2"], pk.AU
    mee0, meef = np.array(prob["mee0"]), np.array(prob["meef"])
    n_rev = int(math.floor((meef[5] - mee0[5]) / (2 * math.pi)))
    posvel0 = pk.mee2ic(mee0.tolist(), mu)
    posvelf = pk.mee2ic(meef.tolist(), mu)
    udp = pk.trajopt.pontryagin_equinoctial_mass(
        posvel0=[list(posvel0[0]), list(posvel0[1])], posvelf=[list(posvelf[0]), list(posvelf[1])],
        tof=prob["tof_s"] / pk.DAY2SEC, mu=mu, eps=eps, lambda0=None, T_max=prob["thrust_N"],
        Isp=prob["c_m_s"] / pk.G0, m0=prob["m0_kg"], n_rev=n_rev, L=L, MU=mu, MASS=prob["m0_kg"],
        with_gradient=True, taylor_tolerance=tol, taylor_tolerance_var=tol_var)
    # what the constructor derived from the Cartesian states, before we set the exact MEE
    derived_Lf = float(udp.eqf[5])
    udp.eq0 = (mee0 * [1 / L, 1, 1, 1, 1, 1]).tolist()
    udp.eqf = (meef * [1 / L, 1, 1, 1, 1, 1]).tolist()
    return udp, {"n_rev_pykep": n_rev, "constructor_Lf_minus_target": derived_Lf - float(meef[5])}


def make_fun(udp):
    import numpy as np
    n = len(udp.get_bounds()[0])

    def fun(x):
        f = np.asarray(udp.fitness(x)[1:])
        J = np.asarray(udp.gradient(x)).reshape(n, n)
        return f, J
    return fun


def solve(udp, x0, tol):
    from scipy.optimize import root
    import numpy as np
    n = len(x0)
    sol = root(make_fun(udp), x0, jac=True, method="hybr", tol=tol,
               options={"factor": 1.0, "diag": np.ones(n)})
    return sol


def final_mass(udp, x):
    udp.set_ta_state(x)
    udp.ta.propagate_until(udp.tof)
    return float(udp.ta.state[6]) * udp.MASS


def run_problem(pk, name, prob, args):
    import numpy as np
    t0 = time.perf_counter()
    udp, info = build_udp(pk, prob, args.eps, args.tol, args.tol_var)
    x_probe = np.array(udp.get_bounds()[1]) * 0.5
    udp.fitness(x_probe)
    udp.gradient(x_probe)                     # Taylor integrators are compiled (or cached) here
    setup_s = time.perf_counter() - t0
    lb, ub = (np.asarray(b) for b in udp.get_bounds())
    rng = np.random.default_rng(args.seed)
    starts, total, first = [], 0.0, None
    t_prop = time.perf_counter()
    udp.fitness(x_probe)
    prop_s = time.perf_counter() - t_prop
    k = 0
    # at least --starts random starts; if none succeeded, go on (same stream) up to --max-starts
    while k < args.starts or (first is None and k < args.max_starts):
        x0 = lb + (ub - lb) * rng.random(lb.size)
        t1 = time.perf_counter()
        try:
            sol = solve(udp, x0, args.xtol)
            f = np.asarray(sol.fun)
            fmax = float(np.max(np.abs(f)))
            ok = bool(sol.success and fmax <= args.ftol)
            rec = {"hybr_success": bool(sol.success), "max_abs_F": fmax, "nfev": int(sol.nfev),
                   "njev": int(getattr(sol, "njev", 0)), "message": str(sol.message)}
        except Exception as exc:          # an integration failure counts as a failed start
            ok, rec, sol = False, {"error": repr(exc)}, None
        dt = time.perf_counter() - t1
        total += dt
        rec.update({"start": k, "success": ok, "time_s": dt})
        if ok:
            rec["final_mass_kg"] = final_mass(udp, sol.x)
            rec["x"] = sol.x.tolist()
            if first is None:
                first = total
        starts.append(rec)
        print(f"[pykep {name}] start {k}: {'ok' if ok else 'fail'} {dt:.2f}s "
              f"{rec.get('final_mass_kg', '')}", file=sys.stderr, flush=True)
        k += 1
    succ = [s for s in starts if s["success"]]
    out = {"problem": name, "settings": {"eps": args.eps, "lambda0": None, "taylor_tolerance": args.tol,
                                         "taylor_tolerance_var": args.tol_var, "method": "hybr",
                                         "factor": 1.0, "diag": "ones", "tol": args.xtol,
                                         "success_max_abs_F": args.ftol, "seed": args.seed,
                                         "min_starts": args.starts, "max_starts": args.max_starts},
           **info, "setup_compile_s": setup_s, "one_propagation_s": prop_s,
           "starts": len(starts), "successes": len(succ),
           "success_rate": (len(succ) / len(starts)) if starts else None,
           "total_time_s": total, "time_to_first_success_s": first,
           "expected_time_to_first_success_s": (total / len(succ)) if succ else None,
           "runs": starts}
    if args.from_ours:
        out["from_ours"] = solve_from(udp, np.asarray(json.loads(args.from_ours), float), args)
    if succ:
        masses = np.array([s["final_mass_kg"] for s in succ])
        best = succ[int(np.argmax(masses))]
        out.update({"final_mass_kg": float(masses.max()), "final_mass_kg_all_successes": masses.tolist(),
                    "distinct_solutions": int(len(np.unique(np.round(masses, 3)))),
                    "x_best": best["x"]})
        if args.eps_cont:
            out["eps_continuation"] = eps_continuation(pk, udp, np.array(best["x"]), args)
    return out


def solve_from(udp, x0, args):
    """Cross-check, not part of pykep's multistart statistics: one hybr solve of pykep's own
    problem started from our converged costates mapped to pykep's decision vector."""
    import numpy as np
    t1 = time.perf_counter()
    f0 = float(np.max(np.abs(udp.fitness(x0)[1:])))
    sol = solve(udp, x0, args.xtol)
    fmax = float(np.max(np.abs(sol.fun)))
    ok = bool(sol.success and fmax <= args.ftol)
    rec = {"x0": x0.tolist(), "max_abs_F_at_x0": f0, "success": ok, "max_abs_F": fmax, "nfev": int(sol.nfev),
           "time_s": time.perf_counter() - t1, "x": sol.x.tolist(),
           "max_abs_x_change": float(np.max(np.abs(sol.x - x0)))}
    if ok:
        rec["final_mass_kg"] = final_mass(udp, sol.x)
    return rec


def eps_continuation(pk, udp, x, args):
    """From the best solution at args.eps down to args.eps_cont: one hybr solve per step in
    log ε (factor 10 per step; a failed step is retried with half the log-step, at most 8 times).
    The same generic schedule is used for every problem."""
    import numpy as np
    rows = []
    eps, dlog, fails = args.eps, 1.0, 0
    target = args.eps_cont
    while eps > target * 1.0001 and fails <= 8:
        trial = max(eps / 10.0**dlog, target)
        udp.eps = trial
        t1 = time.perf_counter()
        try:
            sol = solve(udp, x, args.xtol)
            fmax = float(np.max(np.abs(sol.fun)))
            ok = bool(sol.success and fmax <= args.ftol)
        except Exception:
            ok, fmax = False, float("nan")
        row = {"eps": trial, "success": ok, "max_abs_F": fmax, "time_s": time.perf_counter() - t1}
        if ok:
            x, eps = sol.x, trial
            row["final_mass_kg"] = final_mass(udp, x)
        else:
            dlog, fails = dlog / 2.0, fails + 1
        rows.append(row)
    udp.eps = args.eps
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--problems", nargs="+", default=None)
    ap.add_argument("--starts", type=int, default=20)
    ap.add_argument("--max-starts", type=int, default=0,
                    help="if no start of the first --starts succeeded, continue up to this many")
    ap.add_argument("--seed", type=int, default=20260522)
    ap.add_argument("--eps", type=float, default=1e-5)
    ap.add_argument("--tol", type=float, default=1e-10)
    ap.add_argument("--tol-var", type=float, default=1e-4)
    ap.add_argument("--xtol", type=float, default=1e-8)
    ap.add_argument("--ftol", type=float, default=1e-6)
    ap.add_argument("--eps-cont", type=float, default=0.0, help="continue the best solution down to this eps")
    ap.add_argument("--from-ours", default="", help="JSON list: pykep decision vector mapped from our costates")
    ap.add_argument("--placeholders-only", action="store_true")
    args = ap.parse_args(argv)
    made = ensure_placeholders()
    if args.placeholders_only:
        print(json.dumps({"placeholders_written": made}))
        return
    import pykep as pk
    import numpy as np
    import scipy
    sys.path.insert(0, str(HERE))
    from peer_problems import problems
    probs = problems()
    names = args.problems or list(probs)
    out = {"pykep_version": pk.__version__, "numpy": np.__version__, "scipy": scipy.__version__,
           "placeholders_written": made, "problems": {}}
    for name in names:
        out["problems"][name] = run_problem(pk, name, probs[name], args)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
