"""Command line: ``spaceopt solve`` for a user's own transfer (LP -> T_min verdict -> OT).

Example (dissertation §4.1 E1)::

    spaceopt solve --initial a_km=36621,e=0.812375413,i_deg=7,raan_deg=0,argp_deg=178 \\
                   --final a_km=42164,e=0,i_deg=0 --m0-kg 1000 --isp-s 1520 --thrust-n 15 \\
                   --n-rev 2 --l0-deg 300 --out results/user/e1

Orbit elements carry their units in the key names. Exit status: 0 when the chain finished
(including the verdict "no transfer exists"), 1 for bad input (one line naming the key and the
value), 2 when a continuation did not converge (its diagnosis is written next to the artifacts).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

ORBIT_KEYS = {"a_km": 1e3, "e": 1.0, "i_deg": 1.0, "raan_deg": 1.0, "argp_deg": 1.0}


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        print(f"error: {message}", file=sys.stderr)
        sys.exit(1)


def parse_orbit(text: str, key: str):
    from .errors import ConfigError
    from .indirect.transfer import Orbit

    vals = {}
    for part in filter(None, text.split(",")):
        if "=" not in part:
            raise ConfigError(key, part, "expected name=value pairs, e.g. a_km=42164,e=0,i_deg=0")
        name, raw = (s.strip() for s in part.split("=", 1))
        if name not in ORBIT_KEYS:
            raise ConfigError(f"{key}.{name}", raw,
                              f"unknown element (expected {', '.join(ORBIT_KEYS)}; units are part of the name)")
        try:
            v = float(raw)
        except ValueError:
            raise ConfigError(f"{key}.{name}", raw, "not a number") from None
        if not math.isfinite(v):
            raise ConfigError(f"{key}.{name}", raw, "must be finite")
        vals[name] = v * ORBIT_KEYS[name]
    for need in ("a_km", "e", "i_deg"):
        if need not in vals:
            raise ConfigError(f"{key}.{need}", None, "missing")
    orbit = Orbit(vals["a_km"], vals["e"], vals["i_deg"], vals.get("raan_deg", 0.0), vals.get("argp_deg", 0.0))
    orbit.check(key)
    if orbit.a * (1 - orbit.e) < 6.371e6 * 0.5:
        raise ConfigError(f"{key}.a_km", vals["a_km"] / 1e3, "perigee radius is far inside the Earth")
    return orbit


def _positive(name):
    from .errors import ConfigError

    def conv(text):
        try:
            v = float(text)
        except ValueError:
            raise ConfigError(name, text, "not a number") from None
        if not (math.isfinite(v) and v > 0):
            raise ConfigError(name, text, "must be a positive number")
        return v
    return conv


def build_parser():
    p = _Parser(prog="spaceopt", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    s = sub.add_parser("solve", help="LP -> T_min existence check -> OT for one transfer")
    s.add_argument("--initial", required=True, help="initial orbit, e.g. a_km=36621,e=0.81,i_deg=7,raan_deg=0,argp_deg=178")
    s.add_argument("--final", required=True, help="final orbit, same keys")
    s.add_argument("--m0-kg", required=True)
    s.add_argument("--isp-s", required=True)
    s.add_argument("--thrust-n", required=True)
    s.add_argument("--n-rev", required=True)
    s.add_argument("--l0-deg", default="0")
    s.add_argument("--mu-km3-s2", default="398600.436")
    s.add_argument("--eps-final", default="1e-5")
    s.add_argument("--out", default="results/user")
    s.add_argument("--quiet", action="store_true")
    return p


def solve(args) -> int:
    from .errors import ConfigError, ConvergenceError
    from .indirect import chain
    from .indirect.continuation import ContinuationOptions
    from .indirect.transfer import Transfer
    from .studies import multirev
    from . import artifacts

    try:
        l0 = float(args.l0_deg)
    except ValueError:
        raise ConfigError("l0_deg", args.l0_deg, "not a number") from None
    tr = Transfer(parse_orbit(args.initial, "initial"), parse_orbit(args.final, "final"), l0,
                  _positive("n_rev")(args.n_rev), _positive("m0_kg")(args.m0_kg),
                  _positive("isp_s")(args.isp_s), _positive("thrust_n")(args.thrust_n),
                  mu=_positive("mu_km3_s2")(args.mu_km3_s2) * 1e9, eps_final=_positive("eps_final")(args.eps_final))
    out = Path(args.out)
    cfg = {"cli": vars(args)}
    opts = ContinuationOptions(verbose=not args.quiet)
    t0 = time.perf_counter()
    try:
        lp = chain.solve_lp(tr, opts)
        multirev.save(lp, out / "lp.json", cfg, time.perf_counter() - t0)
        tm = chain.solve_tmin(lp, opts)
        multirev.save(tm, out / "tmin.json", cfg, time.perf_counter() - t0)
        verdict = chain.existence_verdict(tm, tr.thrust)
        artifacts.write_json(out / "verdict.json", {"verdict": verdict, "provenance": artifacts.provenance(cfg)})
        print(verdict["message"])
        if not verdict["exists"]:
            return 0
        ot = chain.solve_ot(lp, tr.thrust, opts)
        sc = multirev.save(ot, out / "ot.json", cfg, time.perf_counter() - t0)["scalars"]
    except ConvergenceError as exc:
        artifacts.write_failure(out / "failure.json", exc, cfg)
        print(f"error: {exc} (diagnosis in {out / 'failure.json'})", file=sys.stderr)
        return 2
    print(json.dumps({k: sc[k] for k in ("tof_days", "m_f_kg", "burn_days", "dv_m_s", "K_f_deg")}, indent=1))
    return 0


def main(argv=None) -> int:
    from .errors import SpaceoptError

    args = build_parser().parse_args(argv)
    try:
        return solve(args)
    except SpaceoptError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
