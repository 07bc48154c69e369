"""The perturbed benchmark's ``measured`` part (benchmarks/perturbed.py) on artifacts written here:
the wall time and the Jacobians of the DAG's route to each perturbed E8 solve, the free-time end
games' Jacobians included (E8 full 500: 97 of its route's 430 on 27 Nov, counted nowhere before)."""
from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import perturbed as bench  # noqa: E402

# (wall time s, solver Jacobians, end-game Jacobians) of the E8 solves at 200 revolutions
SOLVES = {"unperturbed": (100.0, 40, None), "j2": (200.0, 10, 1), "g44": (300.0, 5, 2), "g44_moon_sun": (400.0, 7, 20)}


def write_solve(base: Path, name: str, wall: float, jac: int, end_game: int | None) -> None:
    extra = {} if end_game is None else {"tof_maximum": {"jacobian_evaluations": end_game}}
    (base / f"{name}.json").write_text(json.dumps({
        "provenance": {"wall_time_s": wall}, "solver": {"jacobian_evaluations": jac},
        "transfer": {"n_rev": 200.0}, "extra": extra}))


def test_the_e8_routes_sum_the_solvers_and_the_end_games_jacobians(tmp_path, monkeypatch):
    """--configfile config/e8_smoothed.yaml (every model from the one before it at 200): the route
    to the full model sums all four solves, their end games included."""
    e8 = tmp_path / "perturbed" / "e8"
    e8.mkdir(parents=True)
    for model, (wall, jac, end_game) in SOLVES.items():
        write_solve(e8, f"{model}_n200", wall, jac, end_game)
    monkeypatch.setattr(bench, "CONFIGFILES", [str(ROOT / "config/e8_smoothed.yaml")])
    out = bench.measured(tmp_path)
    assert out["e8"]["g44_moon_sun_n200"]["end_game_jacobian_evaluations"] == 20
    assert out["e8"]["unperturbed_n200"]["end_game_jacobian_evaluations"] == 0     # no end game
    route = out["e8_route_s"]
    assert route["g44_moon_sun_n200"] == {"wall_time_s": 1000.0, "jacobian_evaluations": 40 + 11 + 7 + 27,
                                          "solves": [f"{m}_n200" for m in SOLVES]}
    assert route["j2_n200"]["jacobian_evaluations"] == 51 and "j2_n250" not in route    # only routes that exist


def test_model_from_takes_its_skipped_model_off_the_route(tmp_path):
    """The study config's E8 (model_from: the full model from J2): the route to the full model
    sums the unperturbed, J2 and full solves; 4×4 is a solve beside it."""
    e8 = tmp_path / "perturbed" / "e8"
    e8.mkdir(parents=True)
    for model, (wall, jac, end_game) in SOLVES.items():
        write_solve(e8, f"{model}_n200", wall, jac, end_game)
    route = bench.measured(tmp_path)["e8_route_s"]
    assert route["g44_moon_sun_n200"] == {"wall_time_s": 700.0, "jacobian_evaluations": 40 + 11 + 27,
                                          "solves": ["unperturbed_n200", "j2_n200", "g44_moon_sun_n200"]}
    assert route["g44_n200"]["solves"] == ["unperturbed_n200", "j2_n200", "g44_n200"]
