"""The README's Python example runs as printed, so the README stays true to the library.

The ```python blocks of README.md are executed in order, in one namespace, in a temporary
directory (they write an ephemeris window and the artifacts there). The unperturbed block is
E1 (dissertation §4.1, 2 revolutions, 15 N): its final mass is checked against the published
value of config/published/yun2023_multirev.yaml with that value's tolerance. The perturbed block
(J2 + Moon + Sun, 9 May 2021) must end on a certified maximum of m_f in t_f, move m_f by a small
amount, as a 2.5-day transfer should, and write its artifacts.
"""
import re
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).parents[1]


def python_blocks(markdown: str) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", markdown, flags=re.S | re.M)


def test_python_blocks_are_found():
    assert python_blocks("x\n```python\na = 1\n```\n```sh\nls\n```\n```python\nb = 2\n```\n") == ["a = 1\n", "b = 2\n"]


@pytest.mark.slow
def test_the_readme_python_example_runs_as_printed(tmp_path, monkeypatch):
    blocks = python_blocks((ROOT / "README.md").read_text())
    assert len(blocks) == 2
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    for block in blocks:
        exec(compile(block, str(ROOT / "README.md"), "exec"), ns)

    from spaceopt.studies.multirev import scalars
    from spaceopt.studies.trajectory import sample
    published = yaml.safe_load((ROOT / "config/published/yun2023_multirev.yaml").read_text())
    ref = next(v for v in published["values"] if (v["case"], v["quantity"]) == ("e1_ot_15N", "m_f_kg"))
    m_f = scalars(ns["ot"], sample(ns["ot"], 200))["m_f_kg"]
    assert m_f == pytest.approx(ref["value"], rel=ref["tol"]["rel"])

    assert ns["end_game"]["certified"]
    perturbed = ns["scalars"]
    assert perturbed["tof_days"] == pytest.approx(ns["end_game"]["tof_days"], abs=1e-6)
    assert 0 < abs(perturbed["m_f_kg"] - m_f) < 0.5
    assert {"ot_perturbed.json", "ot_perturbed.npz", "ot_perturbed.rrd", "ephemeris.json"} <= {
        p.name for p in tmp_path.iterdir()}
