import dataclasses
import os
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("MPLBACKEND", "Agg")
sys.path.insert(0, str(ROOT / "workflow" / "scripts"))

# The quick-profile DAG (test_quick_reproduction's module fixture, ~8 min on 2 cores) is by far
# the longest file. `./dev test` hands whole files to the two xdist workers in collection order
# (--dist loadfile --no-loadscope-reorder), so it goes first: started late, as xdist's default
# order by test count had it (17th of 38), it left one worker running it alone at the end.
LONGEST_FIRST = ("test_quick_reproduction.py",)

# Files that start from the same perturbed E1 extremal (the session fixtures below), or that
# compile the same programs, go to one xdist worker together, so that the extremal is solved once
# and the programs are compiled once (the worker's traces, then the persistent cache): on two
# workers at the same time each file compiled them for itself. test_cli's E9 check solves the
# LP and OT under J2 with e1_j2_ot's programs (same layouts and step cap: measured, 3 programs).
ONE_WORKER = {"test_exact_switching.py": "e1_j2", "test_tmin_bound_model.py": "e1_j2", "test_cli.py": "e1_j2",
              "test_thrust_family.py": "e1_j2",
              "test_free_time.py": "e1_g22_era", "test_scan_families.py": "e1_g22_era"}

# Files that compile programs of the quick DAG's jobs run last in their group, when those jobs
# have put them in the persistent cache (the step cap is traced, so a test's programs and a
# study's are the same): test_cli's E9 check solves E9's LP, T_min and OT under J2, as the DAG's
# E9 solve and existence jobs do. First in its group, it compiled them at the same time they did.
AFTER_THE_DAG = ("test_cli.py",)
EPOCH = "2021-05-09T12:00:00"


def pytest_collection_modifyitems(items):
    items.sort(key=lambda item: (item.path.name not in LONGEST_FIRST, item.path.name in AFTER_THE_DAG))


@pytest.hookimpl(optionalhook=True)      # an xdist hook: pytest without xdist runs too
def pytest_xdist_make_scheduler(config, log):
    """--dist loadfile with the files of one ONE_WORKER group as one unit of work."""
    if config.getoption("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    class OneWorkerScheduling(LoadFileScheduling):
        def _split_scope(self, nodeid):
            path = super()._split_scope(nodeid)
            return ONE_WORKER.get(Path(path).name, path)

    return OneWorkerScheduling(config, log)


def e1_transfer(**changes):
    """The E1 transfer of config/studies/multirev.yaml (2 revolutions), with ``changes``."""
    from spaceopt.studies import multirev_config
    cfg = yaml.safe_load((ROOT / "config" / "studies" / "multirev.yaml").read_text())["multirev"]
    return dataclasses.replace(multirev_config.transfer_from_config(cfg, "e1"), **changes)


@pytest.fixture(scope="session")
def e1_j2_ot():
    """E1 OT 15 N under J2 at EPOCH, smoothed at ε_f = 1e-5 (LP with J2 → OT → ε)."""
    from spaceopt.indirect import chain
    tr = e1_transfer(perturbations={"geopotential": "j2"}, epoch_utc=EPOCH)
    return chain.solve_ot(chain.solve_lp(tr, perturbed=True), 15.0)


@pytest.fixture(scope="session")
def e1_g22_era():
    """E1 OT 15 N (2 revolutions) with the EGM96 2×2 geopotential (J2 and the tesseral C22/S22)
    on the Earth rotation angle at EPOCH, from the unperturbed OT extremal with the
    perturbations switched on (studies.perturbed), before the free-time end game; and that
    unperturbed extremal. 2×2 rather than the studies' 4×4: H depends on t the same way, and the
    programs compile ~30 % faster."""
    from spaceopt.indirect import chain
    from spaceopt.indirect.continuation import ContinuationOptions
    from spaceopt.studies import perturbed as P
    quiet = ContinuationOptions(verbose=False)
    tr = e1_transfer()
    ot = chain.solve_ot(chain.solve_lp(tr, quiet), 15.0, quiet)
    tr_p = dataclasses.replace(tr, perturbations={"geopotential": {"degree": 2, "order": 2}, "earth_angle": "era"},
                               epoch_utc=EPOCH)
    return P.perturb_from_unperturbed(ot, tr_p, "e1 g22", options=quiet), ot
