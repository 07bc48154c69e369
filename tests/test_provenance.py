"""Provenance and determinism of artifacts and figures (design.md, "Artifacts"; conventions.md)."""
import difflib
import json
import shutil
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest

from spaceopt.artifacts import (PACKAGES, code_version, config_hash, provenance, read_json, read_npz,
                                write_json, write_npz)

ROOT = Path(__file__).resolve().parents[1]
CFG = {"study": {"case": "e1", "thrust_N": 0.25, "revs": [2, 100]}, "results_dir": "results"}


def _payload(wall):
    return {"scalars": {"T_min_N": 7.85384929, "m_f_kg": np.float64(866.77804), "K_f_deg": 719.958532537,
                        "steps": np.int64(42), "converged": np.bool_(True)},
            "provenance": provenance(CFG, wall_time_s=wall)}


def test_provenance_block_has_config_hash_commit_packages_wall_time():
    prov = provenance(CFG, wall_time_s=1.5)
    assert prov["config_hash"] == config_hash(CFG) and len(prov["config_hash"]) == 64
    assert set(prov["code"]) == {"commit", "dirty"} and isinstance(prov["code"]["dirty"], bool)
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    if head:
        assert prov["code"]["commit"] == head
    assert set(prov["packages"]) == set(PACKAGES)
    for name in ("numpy", "jax", "snakemake"):
        assert prov["packages"][name] == metadata.version(name)
    assert prov["wall_time_s"] == 1.5


def test_config_hash_ignores_key_order_and_sees_every_value():
    reordered = {"results_dir": "results", "study": {"revs": [2, 100], "thrust_N": 0.25, "case": "e1"}}
    assert config_hash(reordered) == config_hash(CFG)
    changed = json.loads(json.dumps(CFG))
    changed["study"]["thrust_N"] = 0.2500001
    assert config_hash(changed) != config_hash(CFG)


def test_dirty_flag_is_a_bool_and_commit_known_in_a_git_checkout():
    cv = code_version()
    assert isinstance(cv["dirty"], bool)
    if (ROOT / ".git").exists():
        assert len(cv["commit"]) == 40


def test_the_code_version_is_the_tree_the_process_loaded_not_a_later_commit(monkeypatch):
    from spaceopt import artifacts
    loaded = code_version()
    monkeypatch.setattr(artifacts, "_git", lambda *args: "f" * 40 if args[0] == "rev-parse" else "")
    assert code_version() == loaded


def test_same_data_gives_identical_bytes_except_wall_time(tmp_path):
    a, b, c = tmp_path / "a.json", tmp_path / "b.json", tmp_path / "c.json"
    write_json(a, _payload(2.0))
    write_json(b, _payload(2.0))
    assert a.read_bytes() == b.read_bytes()
    write_json(c, _payload(3.25))
    da, dc = json.loads(a.read_text()), json.loads(c.read_text())
    assert da["provenance"].pop("wall_time_s") != dc["provenance"].pop("wall_time_s")
    assert da == dc
    # and apart from that one field the files differ in exactly one line
    diff = [(x, y) for x, y in zip(a.read_text().splitlines(), c.read_text().splitlines()) if x != y]
    assert len(diff) == 1 and "wall_time_s" in diff[0][0]


def test_numbers_round_trip_exactly(tmp_path):
    write_json(tmp_path / "x.json", _payload(None))
    s = read_json(tmp_path / "x.json")["scalars"]
    assert s["T_min_N"] == 7.85384929 and s["m_f_kg"] == 866.77804 and s["K_f_deg"] == 719.958532537
    assert s["steps"] == 42 and s["converged"] is True


def test_npz_companion_is_byte_stable_and_checksummed(tmp_path):
    t = np.linspace(0, 1, 101)
    arrays = {"t": t, "r": np.c_[np.cos(t), np.sin(t), t], "m": 1000 - t}
    for d in ("one", "two"):
        write_npz(tmp_path / d / "traj.npz", **arrays)
        write_json(tmp_path / d / "ot.json", _payload(1.0), companions={"trajectory": tmp_path / d / "traj.npz"})
    assert (tmp_path / "one/traj.npz").read_bytes() == (tmp_path / "two/traj.npz").read_bytes()
    assert (tmp_path / "one/ot.json").read_bytes() == (tmp_path / "two/ot.json").read_bytes()
    back = read_npz(tmp_path / "one" / "ot.json")
    np.testing.assert_array_equal(back["r"], arrays["r"])


@pytest.mark.parametrize("suffix", [".png", ".pdf"])
def test_figures_are_byte_stable(tmp_path, monkeypatch, suffix):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1767225600")
    from spaceopt.report.figures import plt, save_figure

    def draw(path):
        fig, ax = plt.subplots(figsize=(4, 3))
        t = np.linspace(0, 10, 200)
        ax.plot(t, np.sin(t), label="S")
        ax.fill_between(t, 0, np.sin(t) > 0, alpha=0.2, label="burn")
        ax.set_xlabel("t, d")
        ax.legend()
        return save_figure(fig, path, formats=(suffix,))

    (p1,) = draw(tmp_path / "one" / "fig")
    (p2,) = draw(tmp_path / "two" / "fig")
    b1, b2 = p1.read_bytes(), p2.read_bytes()
    assert len(b1) > 1000 and b1 == b2
    if suffix == ".pdf":
        assert b"CreationDate" not in b1 and b"Producer" not in b1
    else:
        assert b"Software" not in b1


def test_figures_byte_stable_without_source_date_epoch(tmp_path, monkeypatch):
    """save_figure strips the dates itself: no SOURCE_DATE_EPOCH needed."""
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    from spaceopt.report.figures import plt, save_figure

    out = []
    for d in ("a", "b"):
        fig, ax = plt.subplots()
        ax.plot([0, 1], [1, 0])
        out.append([p.read_bytes() for p in save_figure(fig, tmp_path / d / "f")])
    assert out[0] == out[1]


def _pdf_difference(a: Path, b: Path) -> str:
    """What differs between two PDFs, for the failure message: sizes and, with pdftotext, the
    first differing lines of their text (the flake seen under load: one build a pass behind)."""
    out = [f"{a.name}: {a.stat().st_size} B, {b.name}: {b.stat().st_size} B"]
    if shutil.which("pdftotext"):
        texts = [subprocess.run(["pdftotext", str(p), "-"], capture_output=True, text=True).stdout.splitlines()
                 for p in (a, b)]
        out += [line for line in difflib.unified_diff(*texts, lineterm="", n=1)][:40]
    return "\n".join(out)


@pytest.mark.skipif(shutil.which("pdflatex") is None, reason="TeX is not installed (./dev setup installs it)")
def test_paper_pdf_is_byte_stable(tmp_path):
    """Two builds of the paper from the same generated fragments give identical PDF bytes."""
    from spaceopt.report import paper as P
    from spaceopt.report.figures import plt, save_figure
    from spaceopt.report.scoreboard import build

    res = tmp_path / "results"
    fig, ax = plt.subplots(figsize=(3, 2))
    ax.plot([0, 1, 2], [1, 0, 1])
    (fig_pdf,) = save_figure(fig, res / "toy" / "figures" / "shape", formats=(".pdf",))
    (res / "paper").mkdir(parents=True)
    (res / "paper" / "sections.tex").write_text(P.sections_tex(res, figures=[fig_pdf]))
    (res / "paper" / "errata.tex").write_text(P.errata_tex(P.load_errata(ROOT / "config" / "errata.yaml")))
    (res / "paper" / "performance.tex").write_text(P.performance_tex([]))
    build([], res / "report" / "scoreboard.csv", res / "report" / "scoreboard.md", res / "report" / "scoreboard.tex")
    pdfs = []
    for name in ("one", "two"):
        out = tmp_path / f"{name}.pdf"
        proc = subprocess.run([sys.executable, str(ROOT / "workflow" / "scripts" / "paper_build.py"),
                               "--tex", "paper/paper.tex", "--results", str(res),
                               "--build", str(tmp_path / f"build_{name}"), "--out", str(out),
                               "--epoch", "1767225600"], cwd=ROOT, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr[-3000:]
        pdfs.append(out.read_bytes())
    assert pdfs[0][:5] == b"%PDF-"
    assert pdfs[0] == pdfs[1], _pdf_difference(tmp_path / "one.pdf", tmp_path / "two.pdf")
    if shutil.which("pdfinfo"):
        info = subprocess.run(["pdfinfo", str(tmp_path / "one.pdf")], capture_output=True, text=True).stdout
        assert "CreationDate" not in info and "ModDate" not in info      # no wall-clock dates


def test_failure_records_are_written_next_to_the_artifact_and_cleared_by_the_next_run(tmp_path):
    from spaceopt import artifacts
    from spaceopt.errors import ConvergenceError
    out = tmp_path / "e6" / "2021-05-19.json"
    exc = ConvergenceError("e6/2021-05-19: continuation failed", {"reason": "turned back", "tau": -1.1})
    for suffix in artifacts.FAILURE_SUFFIXES:
        artifacts.write_failure(artifacts.failure_path(out, suffix), exc, {"a": 1}, 2.0)
    record = artifacts.read_json(tmp_path / "e6" / "2021-05-19.failure.json")
    assert record["error"] == str(exc) and record["diagnosis"]["tau"] == -1.1
    assert record["provenance"]["wall_time_s"] == 2.0
    (tmp_path / "e6" / "2021-05-18.failure.json").write_text("{}")       # another date's record stays
    artifacts.clear_failures(out)
    assert sorted(p.name for p in (tmp_path / "e6").iterdir()) == ["2021-05-18.failure.json"]
