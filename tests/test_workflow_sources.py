"""A solver change reruns the solves: every spaceopt module a solve job's script loads is among
the library sources its rule declares as inputs (workflow/rules/common.smk, ``lib_sources``).

Checked at import time: the modules a script's ``from spaceopt… import`` lines load, in a fresh
interpreter (the force models a transfer builds later, ``forces``, ``ephemeris``, ``frames``, are
declared by the perturbed rules too). Left out: the package's ``__init__`` files, ``errors`` and
``config`` (messages, config-file parsing and the thread count; no numbers of a solution).

The same import lines show that the report jobs' scripts load no solver.
"""
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOT_NUMERICS = {"src/spaceopt/errors.py", "src/spaceopt/config.py"}


def declared(rules: str, name: str) -> set[str]:
    """The files of ``NAME = lib_sources(...)`` in a rules file, expanded as lib_sources does."""
    text = (ROOT / "workflow/rules" / rules).read_text()
    args = re.search(rf"^{name} = lib_sources\((.*?)\)$", text, re.M | re.S).group(1)
    files = set()
    for pkg in re.findall(r'"([^"]+)"', args):
        p = ROOT / "src/spaceopt" / pkg
        files |= {str(f.relative_to(ROOT)) for f in p.glob("*.py")} if p.is_dir() else {f"src/spaceopt/{pkg}.py"}
    return files


def spaceopt_imports(script: str) -> list[str]:
    """The script's ``from spaceopt… import`` and ``import spaceopt…`` lines, comments dropped."""
    return [re.sub(r"\s*#.*$", "", line) for line in (ROOT / "workflow/scripts" / script).read_text().splitlines()
            if re.match(r"(from spaceopt[\w.]* import |import spaceopt)", line)]


def loaded(script: str) -> set[str]:
    """The spaceopt source files that the script's spaceopt imports load."""
    lines = spaceopt_imports(script)
    code = "\n".join([*lines, "import sys",
                      "print('\\n'.join(m.__file__ for n, m in sys.modules.items() if n.startswith('spaceopt')))"])
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    return {str(Path(f).resolve().relative_to(ROOT)) for f in out.stdout.split()
            if not f.endswith("__init__.py")} - NOT_NUMERICS


@pytest.mark.parametrize("script, rules, name", [
    ("perturbed_solve.py", "perturbed.smk", "PT_SRC"),
    ("multirev_solve.py", "multirev.smk", "SOLVER_SRC"),
    ("sweep_row.py", "sweep.smk", "SW_SRC"),
    ("perturbed_thrust_family.py", "perturbed.smk", "PT_SRC+TF_SRC"),
])
def test_a_solve_rule_declares_every_library_module_its_script_loads(script, rules, name):
    """(``name``: the rule's source lists, joined by '+'.)"""
    assert loaded(script) - set().union(*(declared(rules, n) for n in name.split("+"))) == set()


REPORT_SCRIPTS = ("perturbed_tables.py", "perturbed_paper_section.py", "perturbed_figures.py",
                  "perturbed_existence_table.py", "perturbed_thrust_family_table.py", "force_shares_table.py", "multirev_tables.py", "multirev_paper.py",
                  "multirev_figures.py")


def test_the_report_jobs_import_neither_jax_nor_the_solver():
    """The tables, figures and paper-section jobs read artifacts only: their scripts' spaceopt
    imports load neither JAX, SciPy's integrators nor the solver (1.2-2.9 s of CPU each before
    they were split from the verifier and the solve functions). One process imports them all, one
    script after the other, and names the first script after which a heavy module is loaded."""
    heavy = ("jax", "scipy.integrate", "diffrax", "optimistix", "spaceopt.indirect.chain")
    code = ["import sys"]
    for script in REPORT_SCRIPTS:
        lines = spaceopt_imports(script)
        assert lines, script
        code += [*lines, f"loaded = sorted(m for m in {heavy!r} if m in sys.modules)",
                 f"assert not loaded, ({script!r}, loaded)"]
    out = subprocess.run([sys.executable, "-c", "\n".join(code)], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr[-1500:]
