"""The report built without the §4.2 solves that failed (spaceopt.studies.failed_solves): which
solves are left out, why, and how the config and the paper say it."""
import json
from pathlib import Path

import yaml
from spaceopt.studies import failed_solves as FS, perturbed_config as C, perturbed_report as R

PC = yaml.safe_load((Path(__file__).resolve().parents[1] / "config/studies/perturbed.yaml").read_text())["perturbed"]


def _fail(path, error):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.with_name(path.stem + ".failure.json").write_text(json.dumps({"error": error}))


def test_a_diagnosis_counts_only_where_the_artifact_is_missing(tmp_path):
    art = tmp_path / "e8" / "j2_n450.json"
    assert FS.diagnosis(art) is None                              # not run yet
    _fail(art, "continuation stalled at tau 0.31\nsecond line")
    assert FS.diagnosis(art) == "continuation stalled at tau 0.31"
    art.write_text("{}")                                          # converged later: the old record does not count
    assert FS.diagnosis(art) is None
    art.unlink()
    art.with_name("j2_n450.failure.json").write_text("{not json")
    assert FS.diagnosis(art) == "unreadable diagnosis j2_n450.failure.json"


def test_solves_that_start_from_a_failed_one_are_left_out_with_it():
    """E8-like chains: each model at a count starts from the previous model at that count."""
    models = ["unperturbed", "j2", "g44", "full"]
    runs = [(m, n) for n in (400.0, 450.0) for m in models]
    source = lambda r: None if r[0] == models[0] else (models[models.index(r[0]) - 1], r[1])  # noqa: E731
    why = {("j2", 450.0): "no convergence"}.get
    out = FS.left_out(runs, source, why, name=lambda r: f"{r[0]} at {r[1]:g}")
    assert out == {("j2", 450.0): "no convergence",
                   ("g44", 450.0): "starts from j2 at 450, which failed",
                   ("full", 450.0): "starts from j2 at 450, which failed"}
    assert FS.left_out(runs, source, lambda r: None) == {}


def test_the_config_skips_the_failed_solves_beside_the_configured_ones():
    pc = {"e6": {"skip_dates": ["2021-05-20"], "model": "x"},
          "e8": {"skip_n_rev": {"full": [450]}, "n_rev": [400, 450]}, "run": ["e6", "e8"]}
    out = FS.without_failed(pc, {"2021-05-03": "a"}, {("j2", 400.0): "b", ("full", 400.0): "c"})
    assert out["e6"] == {"skip_dates": ["2021-05-03", "2021-05-20"], "model": "x"}
    assert out["e8"]["skip_n_rev"] == {"full": [450, 400.0], "j2": [400.0]} and out["e8"]["n_rev"] == [400, 450]
    assert pc["e8"]["skip_n_rev"] == {"full": [450]} and pc["e6"]["skip_dates"] == ["2021-05-20"]   # not changed
    assert out["run"] == pc["run"]


def test_the_paper_names_each_failure_with_its_reason():
    text = FS.failures_sentence({"2021-05-17": "step-size underflow"},
                                {("j2", 450.0): "no convergence", ("g44", 450.0): "starts from j2 at 450 revolutions, which failed"})
    assert text.startswith("Failed in this run and left out of the tables and figures")
    assert "E6 2021-05-17 (step-size underflow)" in text
    assert "E8 j2 at 450 revolutions (no convergence)" in text
    assert "E8 g44 at 450 revolutions (starts from j2 at 450 revolutions, which failed)" in text
    assert FS.failures_sentence({}, {}) == ""
    assert "the minimum thrust of E7 j2 (fold)" in FS.failures_sentence({}, {}, {("e7", "j2"): "fold"})
    assert "the E7 g44_moon_sun thrust family carried from j2's (fold)" in FS.failures_sentence(
        {}, {}, family={("e7", "g44_moon_sun", "j2"): "fold"})


def test_the_paper_section_carries_the_failures_escaped_for_latex():
    sentence = FS.failures_sentence({}, {("g44_moon_sun", 400.0): "no root near the end point"})
    text = R.paper_section([], {}, None, {}, [], e8_count_start="chain", smoothing=C.e8_smoothing(PC),
                           e8_steps=C.e8_model_steps(PC), failures=sentence)
    assert "E8 g44\\_moon\\_sun at 400 revolutions (no root near the end point)" in text
    assert "failure.json" in text and "./dev reproduce retries them" in text
