"""Layout of the generated paper fragments: scoreboard notes, performance rows, study sections."""
import json

from spaceopt.report import paper as P
from spaceopt.report import scoreboard as S


def _row(case, quantity, published, ours, status="pass", note="", ref="src", rel="0.001"):
    return {"study": "toy", "case": case, "quantity": quantity, "unit": "kg", "published": published,
            "ours": ours, "rel_diff": rel, "abs_diff": "", "tolerance": "rel 0.01", "status": status,
            "ref": ref, "note": note}


def test_scoreboard_notes_are_numbered_once_below_the_table():
    long_note = "a long explanation, " * 20
    rows = [_row("c1", "m", "1.5", "1.5000001", note=long_note),
            _row("c1", "t", "2", "2.1", status="fail", note=long_note),
            _row("c2", "m", "held back", "7", status="info", note="other"),
            _row("c3", "x", "0.0", "1e-19", rel="inf")]
    tex = S.rows_longtable(rows, "caption", "tab:x")
    table, notes = tex.split(r"\end{longtable}")
    assert long_note.strip()[:30] not in table                  # notes are not in the cells
    assert notes.count(r"\item[1.]") == 1 and notes.count(r"\item[2.]") == 1 and r"\item[3.]" not in notes
    body = [line for line in table.split(r"\endfoot")[1].splitlines() if line.endswith(r"\\") and " & " in line]
    assert body[1].startswith(" & ")                             # repeated case left blank
    assert body[0].rstrip(r" \\").endswith("& 1") and body[1].rstrip(r" \\").endswith("& 1")
    assert r"\textit{held back}" in table
    assert r"\mbox{1e-19} & -- &" in table                       # no relative difference to 0


def test_ours_has_one_digit_more_than_the_published_value():
    assert S.sig_digits("0.0012300") == 5 and S.sig_digits("held back") is None
    assert S.fmt_ours("1.23456789012", "1.23") == "1.23457"      # at least 6 digits
    assert S.fmt_ours("9.294943210987", "9.29495") == "9.294943"
    assert S.fmt_published("180739.34632258452") == "180739.3463"


def test_performance_collapses_repeated_runs(tmp_path):
    bench = {"suite": "toy", "machine": {"cpus": 2},
             "cells": [{"wall_s": t, "n": i} for i, t in enumerate((1.0, 3.0, 2.0))],
             "chain": {"warm_wall_s": 4.0, "compile_overhead_s": 9.0, "cold_wall_s": 13.0}}
    path = tmp_path / "toy.json"
    path.write_text(json.dumps(bench))
    rows = P.collapse_rows(P.benchmark_rows(path))
    by_name = {r["name"]: r for r in rows}
    assert by_name["cells (3 runs)"]["time_s"] == 2.0 and "total 6" in by_name["cells (3 runs)"]["details"]
    assert by_name["chain"]["time_s"] == 4.0 and by_name["chain"]["compile_s"] == 9.0
    tex = P.performance_tex([path])
    assert tex.count("cells (3 runs)") == 1


def test_discrete_section_counts_and_captions():
    from spaceopt.studies import discrete_report as D

    rows = [dict(_row("d1_classical", "burns", "18", "25", status="fail"), unit="") ,
            _row("d1_flown", "fuel_kg", "16326", "16326.3"),
            _row("d3_point1", "V", "1.0", "1", status="info")]
    figs = ["results/discrete/figures/geo_orbits_flown.png", "results/discrete/figures/geo_orbits_flown.pdf",
            "results/discrete/figures/bellman_sup.png", "results/discrete/figures/new_thing.png"]
    tex = D.paper_section(rows, figs)
    assert r"\label{sec:discrete}" in tex and "D2:" not in tex     # parts without output are left out
    assert "Of its 2 published values, 1 pass and 1 fail" in tex
    assert "published 18, ours 25" in tex
    assert "geo_orbits_flown.pdf" in tex and "geo_orbits_flown.png" not in tex
    assert D.CAPTIONS["bellman_sup"] in tex and "new thing" in tex


def test_sweep_failing_cell_reads_as_math():
    from spaceopt.studies import sweep_report as R

    assert R._cell_tex("L0_200_n2") == r"$L_0 = 200^\circ$, 2 rev"
    assert R._tex_math("T_min(L0) +- 1") == r"$T_{min}$($L_0$) $\pm$ 1"
