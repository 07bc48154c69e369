"""Command line: ``spaceopt solve`` for a user's own transfer (LP -> T_min verdict -> OT, then
the perturbations switched on when asked for).

Example (dissertation §4.1 E1)::

    spaceopt solve --initial a_km=36621,e=0.812375413,i_deg=7,raan_deg=0,argp_deg=178 \\
                   --final a_km=42164,e=0,i_deg=0 --m0-kg 1000 --isp-s 1520 --thrust-n 15 \\
                   --n-rev 2 --l0-deg 300 --out results/user/e1

With ``--geopotential j2|4x4`` and/or ``--third-bodies moon,sun`` and a departure epoch
``--epoch-utc``, the existence check is made again with the perturbations on (the minimum thrust
of the perturbed problem, :mod:`spaceopt.studies.existence`; ``tmin_perturbed.json``), and the
perturbed OT solution is computed where it exists: from the unperturbed OT solution, the
perturbations switched on by τ and the path followed in arclength
(:func:`spaceopt.studies.perturbed.perturb_from_unperturbed`, the route of the §4.2 studies), or,
where only the perturbed transfer exists (J2 can make a plane change possible), by the chain from
the zero guess with the perturbations on (``--lp-perturbed``: in its LP too, as E9);
a DE405 window for the Moon and the Sun is cut for the transfer (``ephemeris.json``). The
perturbed solution then goes through the free-time end game of the workflow's solves: the local
maximum of the final mass in the time of flight next to it, certified (``--tof-probe-days``;
:func:`maximise_in_tof`, record ``tof_maximum`` in ``ot_perturbed.json``).

``--switching exact`` solves the minimum-fuel problem on the exact bang-bang map (δ = 1[S > 0],
the switches located on the trajectory, :mod:`spaceopt.indirect.exact_switching`): the chain stops
its descent in ε at ε₁ = 10⁻² and Newton jumps to the ε → 0 limit; the perturbations are then
switched on on that map.

Orbit elements carry their units in the key names. Exit status: 0 when the chain finished
(including the verdict "no transfer exists"), 1 for bad input (one line naming the key and the
value), 2 when a continuation did not converge (its diagnosis is written next to the artifacts).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from pathlib import Path

SCALARS = ("tof_days", "m_f_kg", "burn_days", "dv_m_s", "K_f_deg")
PROBE_TOF_FRACTION = 2e-4           # the end game's probe at most this fraction of the time of flight (E9)
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


def _positive(name, zero: bool = False):
    """A converter of the option ``name`` to a positive float (``zero``: or 0)."""
    from .errors import ConfigError

    def conv(text):
        try:
            v = float(text)
        except ValueError:
            raise ConfigError(name, text, "not a number") from None
        if not (math.isfinite(v) and (v > 0 or zero and v == 0)):
            raise ConfigError(name, text, "must be a positive number" + (" or 0" if zero else ""))
        return v
    return conv


def build_parser():
    p = _Parser(prog="spaceopt", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    s = sub.add_parser("solve", help="LP -> T_min existence check -> OT for one transfer")
    s.add_argument("--initial", required=True, help="initial orbit, e.g. a_km=36621,e=0.81,i_deg=7,raan_deg=0,argp_deg=178")
    s.add_argument("--final", required=True, help="final orbit, same keys")
    s.add_argument("--m0-kg", required=True, help="initial mass, kg")
    s.add_argument("--isp-s", required=True, help="specific impulse, s (exhaust velocity Isp·g0)")
    s.add_argument("--thrust-n", required=True, help="maximum thrust of the minimum-fuel problem, N")
    s.add_argument("--n-rev", required=True,
                   help="revolutions: the final true longitude is L0 + 360°·n_rev (need not be whole)")
    s.add_argument("--l0-deg", default="0", help="initial true longitude L0 = Ω + ω + ν, deg (default 0)")
    s.add_argument("--mu-km3-s2", default="398600.436", help="gravitational parameter, km³/s² (default: Earth's)")
    s.add_argument("--eps-final", default="1e-5",
                   help="the smoothing ε at which the minimum-fuel problem is solved (default 1e-5)")
    s.add_argument("--geopotential", default="none",
                   help="none | j2 | DxO (EGM96 degree x order, e.g. 4x4): the OT solution is then continued "
                        "into the perturbed problem")
    s.add_argument("--third-bodies", default="", help="comma list of moon, sun (DE405)")
    s.add_argument("--epoch-utc", help="departure epoch, e.g. 2021-05-09T12:00:00 (needed with perturbations)")
    s.add_argument("--earth-angle", default="era", help="era | gast: Earth rotation of the geopotential")
    s.add_argument("--lp-perturbed", action="store_true",
                   help="solve the perturbed chains' LP with the perturbations on (as E9 does: J2's node "
                        "precession makes the plane change)")
    s.add_argument("--switching", default="smoothed",
                   help="smoothed | exact: the minimum-fuel problem smoothed at --eps-final, or its "
                        "bang-bang limit with the switches located on the trajectory")
    s.add_argument("--tof-probe-days",
                   help="the free-time end game's probe of a perturbed solution, in days (default: 0.05, "
                        "at most 2e-4 of the time of flight); 0 turns the end game off")
    s.add_argument("--out", default="results/user", help="folder of the artifacts (default results/user)")
    s.add_argument("--quiet", action="store_true", help="no progress lines, only the results")
    return p


def solve(args) -> int:
    from .errors import ConfigError, ConvergenceError
    from .indirect import chain
    from .indirect.continuation import ContinuationOptions
    from .indirect.transfer import SWITCHINGS, Transfer
    from .studies import existence, multirev, perturbed
    from . import artifacts

    try:
        l0 = float(args.l0_deg)
    except ValueError:
        raise ConfigError("l0_deg", args.l0_deg, "not a number") from None
    tr = Transfer(parse_orbit(args.initial, "initial"), parse_orbit(args.final, "final"), l0,
                  _positive("n_rev")(args.n_rev), _positive("m0_kg")(args.m0_kg),
                  _positive("isp_s")(args.isp_s), _positive("thrust_n")(args.thrust_n),
                  mu=_positive("mu_km3_s2")(args.mu_km3_s2) * 1e9, eps_final=_positive("eps_final")(args.eps_final))
    perturbations = parse_perturbations(args)
    switching = args.switching.strip().lower()
    if switching not in SWITCHINGS:
        raise ConfigError("switching", args.switching, f"expected one of {', '.join(SWITCHINGS)}")
    probe = None if args.tof_probe_days is None else _positive("tof_probe_days", zero=True)(args.tof_probe_days)
    epoch = args.epoch_utc
    out = Path(args.out)
    cfg = {"cli": vars(args)}
    opts = ContinuationOptions(verbose=not args.quiet)
    t0 = time.perf_counter()
    try:
        lp = chain.solve_lp(tr, opts)
        multirev.save(lp, out / "lp.json", cfg, time.perf_counter() - t0)
        tm = chain.solve_tmin(lp, opts)
        tm_tof_days = multirev.save(tm, out / "tmin.json", cfg, time.perf_counter() - t0)["scalars"]["tof_days"]
        verdict = chain.existence_verdict(tm, tr.thrust)
        verdicts = {"verdict": verdict}
        print(verdict["message"])
        if perturbations:
            # the existence check with the perturbations on (spaceopt.studies.existence): the
            # perturbations can make a transfer possible that is not without them (E9: J2 makes the
            # plane change), or the reverse; the ephemeris window is cut for the slowest transfer,
            # the unperturbed T_min one
            tr_p = dataclasses.replace(tr, perturbations=perturbations, epoch_utc=epoch,
                                       ephemeris=_ephemeris_window(perturbations, epoch, tm_tof_days, out, cfg))
            tm_p, verdicts["verdict_perturbed"] = existence.solve(tr_p, "perturbed", lp_perturbed=args.lp_perturbed,
                                                                  options=opts)
            tof_days = perturbed.save(tm_p, out / "tmin_perturbed.json", cfg, time.perf_counter() - t0,
                                      tm_p.extra)["scalars"]["tof_days"]
            print("perturbed: " + verdicts["verdict_perturbed"]["message"])
        artifacts.write_json(out / "verdict.json", {**verdicts, "provenance": artifacts.provenance(cfg)})
        perturbed_exists = bool(perturbations) and verdicts["verdict_perturbed"]["exists"]
        if not verdict["exists"] and not perturbed_exists:
            return 0
        if verdict["exists"]:
            ot = chain.solve_ot(lp, tr.thrust, opts, switching=switching)
            sc = multirev.save(ot, out / "ot.json", cfg, time.perf_counter() - t0)["scalars"]
            tof_days = sc["tof_days"]
            print(json.dumps({k: sc[k] for k in SCALARS}, indent=1))
        if perturbed_exists:
            # from the unperturbed extremal where there is one, else by the chain from the zero
            # guess with the perturbations on (the route of the §4.2 E9 solves)
            pert = (perturbed.perturb_from_unperturbed(ot, tr_p, "perturbed", options=opts) if verdict["exists"]
                    else perturbed.solve_for(tr_p, "perturbed", lp_perturbed=args.lp_perturbed, options=opts,
                                             switching=switching)[1])
            pert, end_game = maximise_in_tof(pert, probe, tof_days, quiet=args.quiet)
            extra = {} if end_game is None else {"tof_maximum": end_game}
            sc = perturbed.save(pert, out / "ot_perturbed.json", cfg, time.perf_counter() - t0, extra)["scalars"]
            print("perturbed:" + ("" if end_game is None else " " + end_game_verdict(end_game)))
            print(json.dumps({k: sc[k] for k in SCALARS}, indent=1))
    except ConvergenceError as exc:
        artifacts.write_failure(out / "failure.json", exc, cfg)
        print(f"error: {exc} (diagnosis in {out / 'failure.json'})", file=sys.stderr)
        return 2
    return 0


def maximise_in_tof(sol, probe_days: float | None, tof_days: float, quiet: bool = False):
    """The free-time end game of the perturbed solution ``sol``, as every perturbed solve of the
    workflow ends (:func:`spaceopt.indirect.free_time.maximise_final_mass`): the local maximum of
    m_f in t_f next to it, certified by a sign change of p_t(K_f) between fixed-time extremals.
    ``probe_days``: its probes' distance from t_f; None: the library's and workflow's 0.05 d, at most
    2·10⁻⁴ of ``tof_days`` (a time of flight near the solution's), as E9 needs (0.001 d over
    5 d: its m_f falls by 4 g within 0.001 d of the maximum); 0: off. Returns (solution, record
    or None)."""
    from .indirect.free_time import MaximumOptions, maximise_final_mass

    if probe_days is None:
        probe_days = min(MaximumOptions.probe_days, PROBE_TOF_FRACTION * tof_days)
    if probe_days == 0.0:
        return sol, None
    return maximise_final_mass(sol, MaximumOptions(probe_days=probe_days, verbose=not quiet,
                                                   label="perturbed tof maximum"))


def end_game_verdict(record: dict) -> str:
    """One line on the end game's record (:func:`maximise_in_tof`)."""
    if not record["certified"]:
        return (f"the free-time end game certified no maximum of m_f in t_f ({record['status']}); "
                "the free-time solution is kept")
    return (f"a certified local maximum of m_f in t_f at {record['tof_days']:.5f} d "
            f"({record['m_f_gain_kg'] * 1e3:+.3f} g against the free-time Newton point)")


def parse_perturbations(args) -> dict | None:
    """The force model of ``--geopotential``, ``--third-bodies``, ``--earth-angle`` as a
    :func:`spaceopt.forces.build_model` config (None: unperturbed), checked by building it."""
    from .errors import ConfigError

    text = args.geopotential.strip().lower()
    if text in ("", "none"):
        geo = None
    elif text == "j2":
        geo = "j2"
    else:
        try:
            degree, order = (int(v) for v in text.split("x"))
        except ValueError:
            raise ConfigError("geopotential", args.geopotential, "expected none, j2 or DxO, e.g. 4x4") from None
        geo = {"degree": degree, "order": order}
    bodies = [b.strip().lower() for b in args.third_bodies.split(",") if b.strip()]
    if geo is None and not bodies:
        return None
    cfg = {"geopotential": geo, "third_bodies": bodies, "earth_angle": args.earth_angle}
    if args.epoch_utc is None:
        raise ConfigError("epoch_utc", None, "perturbations need a departure epoch, e.g. --epoch-utc 2021-05-09T12:00:00")
    from .ephemeris import check_in_de405
    from .forces import THIRD_BODY_MU, build_model
    build_model({**cfg, "third_bodies": []}, args.epoch_utc, key="perturbations")   # names a bad value
    for b in bodies:
        if b not in THIRD_BODY_MU:
            raise ConfigError("third_bodies", b, f"unknown body; expected one of {', '.join(sorted(THIRD_BODY_MU))}")
    if bodies:
        check_in_de405(args.epoch_utc, "epoch_utc")
    return cfg


def _ephemeris_window(perturbations: dict, epoch: str, tof_days: float, out: Path, cfg: dict) -> str | None:
    """A DE405 window of the Moon and the Sun covering the transfer (``out/ephemeris.json``):
    from a day before the epoch to twice the unperturbed time of flight plus 30 days after it
    (perturbations lengthened E5 by 8 %), None when no third body is asked for."""
    if not perturbations["third_bodies"]:
        return None
    from datetime import datetime, timedelta
    from .errors import ConfigError
    from .ephemeris import extract_window, save_window
    t0 = datetime.fromisoformat(epoch)
    start, end = ((t0 + timedelta(days=d)).strftime("%Y-%m-%dT%H:%M:%S") for d in (-1, 2 * tof_days + 30))
    try:
        window = extract_window(start, end, name="cli")
    except ConfigError as exc:        # named after the user's option, not the window's own key
        raise ConfigError("epoch_utc", epoch, f"the Moon and Sun window of this transfer, {start} to {end}: "
                                              f"{exc.reason}") from None
    path = out / "ephemeris.json"
    save_window(window, path, cfg)
    return str(path)


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
