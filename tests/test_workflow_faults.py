"""Faults: an interrupted run resumes, corrupted artifacts are caught, failing steps are clear.

(a) A run killed in the middle (SIGKILL of the whole process group: a crash or a lost node)
    resumes with `snakemake --unlock` then `--rerun-incomplete`, and recomputes only the
    unfinished jobs.
(b) A corrupted or truncated artifact is detected by spaceopt.artifacts.read_json/read_npz
    (ArtifactError), both directly and when a workflow step reads it.
(c) A failing step exits non-zero with a one-line error, and Snakemake names the rule and log.
(d) ./dev reproduce builds the report without the perturbed solves that failed (a second pass),
    and still exits non-zero.

The DAG runs in a temporary copy of the workflow skeleton (Snakefile, common.smk, _step.py,
global config) with small test-only rules written by this file.
"""
import importlib.util
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from workflow_skeleton import make_skeleton, planned_jobs, run_snakemake, snakemake_env

from spaceopt.artifacts import provenance, read_json, read_npz, write_json, write_npz
from spaceopt.errors import ArtifactError

ROOT = Path(__file__).resolve().parents[1]

if importlib.util.find_spec("snakemake") is None:  # pragma: no cover
    pytest.skip("snakemake is not installed (it is a pinned dependency: ./dev setup)", allow_module_level=True)

FAULT_RULES = '''
rule fast:
    output: f"{RESULTS}/faults/fast_{{i}}.txt"
    shell: "echo done {wildcards.i} > {output}"


rule slow:
    input: f"{RESULTS}/faults/fast_1.txt"
    output: f"{RESULTS}/faults/slow.txt"
    params: seconds=config.get("slow_seconds", 60)
    shell:
        "echo partial > {output}; touch {RESULTS}/faults/slow.started; "
        "sleep {params.seconds}; echo complete >> {output}"


rule gather:
    input: expand(f"{RESULTS}/faults/fast_{{i}}.txt", i=[1, 2, 3]), f"{RESULTS}/faults/slow.txt"
    output: f"{RESULTS}/faults/gather.txt"
    shell: "cat {input} > {output}"


rule artifact:
    output: json=f"{RESULTS}/faults/solve.json", npz=f"{RESULTS}/faults/solve.npz"
    shell: "{PY} workflow/scripts/fault_artifact.py write {output.json} {output.npz}"


rule consume:
    input: f"{RESULTS}/faults/solve.json"
    output: f"{RESULTS}/faults/consumed.txt"
    log: f"{RESULTS}/logs/faults/consume.log"
    shell: "{PY} workflow/scripts/fault_artifact.py read {input} {output} 2> {log} || {{ tail -n1 {log} >&2; exit 1; }}"


rule failing:
    output: f"{RESULTS}/faults/failing.txt"
    params: thrust=config.get("bad_thrust", -1.0)
    log: f"{RESULTS}/logs/faults/failing.log"
    shell: "{PY} workflow/scripts/fault_artifact.py fail {params.thrust} {output} 2> {log} || {{ tail -n1 {log} >&2; exit 1; }}"
'''

FAULT_SCRIPT = '''
import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step


def main(mode, *args):
    import numpy as np
    from spaceopt.artifacts import read_json, read_npz, write_json, write_npz
    from spaceopt.errors import ConfigError
    if mode == "write":
        js, npz = args
        write_npz(npz, t=np.linspace(0, 1, 50), m=np.linspace(1000, 900, 50))
        write_json(js, {"m_f_kg": 900.0}, companions={"trajectory": npz})
    elif mode == "read":
        js, out = args
        data = read_json(js)
        traj = read_npz(js)
        Path(out).write_text(f"{data['m_f_kg']} {traj['m'][-1]}\\n")
    elif mode == "fail":
        thrust, out = float(args[0]), args[1]
        if thrust <= 0:
            raise ConfigError("faults.thrust_N", thrust, "must be positive")
        Path(out).write_text("ok\\n")


if __name__ == "__main__":
    run_step(main, *sys.argv[1:])
'''


def make_workflow(tmp: Path) -> Path:
    return make_skeleton(tmp, {"workflow/rules/faults.smk": FAULT_RULES,
                               "workflow/scripts/fault_artifact.py": FAULT_SCRIPT})


def snakemake(root: Path, *args, timeout=120) -> subprocess.CompletedProcess:
    return run_snakemake(root, "--cores", "4", *args, timeout=timeout)


# ----------------------------------------------------------------------------- (a) resume

def test_killed_run_resumes_and_recomputes_only_unfinished_jobs(tmp_path):
    root = make_workflow(tmp_path)
    res = root / "results" / "faults"
    proc = subprocess.Popen([sys.executable, "-m", "snakemake", "--cores", "4", "results/faults/gather.txt"],
                            cwd=root, env=snakemake_env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    try:
        deadline = time.time() + 60
        while not ((res / "slow.started").exists() and all((res / f"fast_{i}.txt").exists() for i in (1, 2, 3))):
            assert proc.poll() is None, "snakemake ended before it could be interrupted"
            assert time.time() < deadline, "the slow job never started"
            time.sleep(0.1)
        time.sleep(0.3)   # let Snakemake record the finished fast jobs
    finally:
        os.killpg(proc.pid, signal.SIGKILL)   # the whole group: snakemake and the running job
        proc.wait(timeout=30)
    assert (res / "slow.txt").read_text() == "partial\n"        # a half-written output is left
    assert not (res / "gather.txt").exists()
    fast_mtimes = {i: (res / f"fast_{i}.txt").stat().st_mtime_ns for i in (1, 2, 3)}

    # Snakemake knows the partial file is incomplete and refuses to use it without being told
    plain = snakemake(root, "-n", "results/faults/gather.txt")
    assert "incomplete" in (plain.stdout + plain.stderr).lower()

    # a killed Snakemake leaves its lock behind: release it, then resume
    assert snakemake(root, "--unlock").returncode == 0
    resumed = snakemake(root, "--rerun-incomplete", "--config", "slow_seconds=0", "--", "results/faults/gather.txt")
    assert resumed.returncode == 0, resumed.stderr
    jobs = planned_jobs(resumed)
    jobs.pop("all", None)
    assert jobs == {"slow": 1, "gather": 1}, jobs                 # the finished fast jobs are kept
    assert {i: (res / f"fast_{i}.txt").stat().st_mtime_ns for i in (1, 2, 3)} == fast_mtimes
    assert (res / "slow.txt").read_text() == "partial\ncomplete\n"
    assert "complete" in (res / "gather.txt").read_text()


# ----------------------------------------------------------------------------- (b) corruption

def _artifact(tmp_path):
    npz = tmp_path / "traj.npz"
    write_npz(npz, t=np.linspace(0, 1, 200), m=np.linspace(1000, 900, 200))
    js = tmp_path / "ot.json"
    write_json(js, {"m_f_kg": 900.0, "provenance": provenance({"a": 1}, 0.1)}, companions={"trajectory": npz})
    return js, npz


def test_intact_artifact_reads(tmp_path):
    js, _ = _artifact(tmp_path)
    assert read_json(js)["m_f_kg"] == 900.0
    assert read_npz(js)["m"][-1] == 900.0


@pytest.mark.parametrize("damage", ["truncate_json", "garbage_json", "empty_json"])
def test_damaged_json_is_detected(tmp_path, damage):
    js, _ = _artifact(tmp_path)
    text = js.read_bytes()
    js.write_bytes({"truncate_json": text[: len(text) // 2], "garbage_json": b"\x00\xff{" + text[3:],
                    "empty_json": b""}[damage])
    with pytest.raises(ArtifactError, match="corrupted or truncated"):
        read_json(js)


@pytest.mark.parametrize("damage", ["truncate_npz", "flip_byte", "delete_npz", "swap_npz"])
def test_damaged_npz_is_detected(tmp_path, damage):
    js, npz = _artifact(tmp_path)
    data = bytearray(npz.read_bytes())
    if damage == "truncate_npz":
        npz.write_bytes(bytes(data[: len(data) - 100]))
    elif damage == "flip_byte":
        data[len(data) // 2] ^= 0x01
        npz.write_bytes(bytes(data))
    elif damage == "delete_npz":
        npz.unlink()
    else:  # a valid NPZ, but not the one the JSON was written with
        write_npz(npz, t=np.linspace(0, 1, 200), m=np.linspace(1000, 901, 200))
    with pytest.raises(ArtifactError, match="checksum mismatch|missing"):
        read_npz(js)
    with pytest.raises(ArtifactError):
        read_json(js)          # the JSON alone already checks its companions


def test_workflow_step_refuses_a_corrupted_input(tmp_path):
    root = make_workflow(tmp_path)
    assert snakemake(root, "results/faults/consumed.txt").returncode == 0
    npz = root / "results" / "faults" / "solve.npz"
    npz.write_bytes(npz.read_bytes()[:-64])                      # truncated behind the workflow's back
    proc = snakemake(root, "--forcerun", "consume", "--", "results/faults/consumed.txt")
    assert proc.returncode != 0
    err = proc.stdout + proc.stderr
    assert re.search(r"error: artifact='[^']*solve\.npz': checksum mismatch", err), err
    assert "Error in rule consume" in err
    assert not (root / "results" / "faults" / "consumed.txt").exists()   # no output from bad input


# ----------------------------------------------------------------------------- (c) failure

def test_failing_step_exits_nonzero_with_one_line_error(tmp_path):
    root = make_workflow(tmp_path)
    proc = snakemake(root, "results/faults/failing.txt")
    assert proc.returncode != 0
    err = proc.stdout + proc.stderr
    # the step's own message: one line naming the key and value, no traceback
    log = (root / "results" / "logs" / "faults" / "failing.log").read_text()
    assert log.strip().splitlines() == ["error: faults.thrust_N=-1.0: must be positive"], log
    assert "Traceback" not in log
    assert "error: faults.thrust_N=-1.0: must be positive" in err
    # the DAG names the rule, the log and gives up
    assert "Error in rule failing" in err
    assert "results/logs/faults/failing.log" in err
    assert "Exiting because a job execution failed" in err
    assert not (root / "results" / "faults" / "failing.txt").exists()


def test_scoreboard_refuses_a_malformed_reproduction_table(tmp_path):
    from spaceopt.report.scoreboard import build

    bad = tmp_path / "study" / "reproduction.csv"
    bad.parent.mkdir()
    bad.write_text("study,case,published,ours\nx,a,1,1\n")          # columns missing
    with pytest.raises(ArtifactError, match=r"reproduction\.csv.*lacks columns"):
        build([bad], tmp_path / "s.csv", tmp_path / "s.md", tmp_path / "s.tex")
    with pytest.raises(ArtifactError, match="missing"):
        build([tmp_path / "nope" / "reproduction.csv"], tmp_path / "s.csv", tmp_path / "s.md", tmp_path / "s.tex")


def test_a_bug_keeps_its_traceback_in_the_log_and_says_one_line(capfd):
    """run_step: an exception that is not a SpaceoptError is a bug; its traceback goes to the
    rule's log (sys.stderr while the script runs), the console gets one line, exit status 1."""
    import io
    from contextlib import redirect_stderr
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "scripts"))
    from _step import run_step
    log = io.StringIO()
    with redirect_stderr(log), pytest.raises(SystemExit) as exit_:
        run_step(lambda: 1 / 0)
    assert exit_.value.code == 1
    assert "Traceback" in log.getvalue() and "ZeroDivisionError" in log.getvalue()
    assert capfd.readouterr().err.strip().splitlines() == [
        "error: internal error ZeroDivisionError: division by zero (traceback in the rule's log)"]


def _dev_tree(tmp_path: Path, snakemake_body: str) -> Path:
    """A copy of ./dev whose set-up has nothing to do and whose snakemake is a stand-in script."""
    root = tmp_path / "checkout"
    (root / ".venv" / "bin").mkdir(parents=True)
    (root / "dev").write_text((ROOT / "dev").read_text())
    for name in ("requirements.lock", "pyproject.toml"):
        (root / name).write_text("")
    (root / ".venv" / "bin" / "python").symlink_to(sys.executable)
    fake = root / ".venv" / "bin" / "snakemake"
    fake.write_text("#!/usr/bin/env bash\necho \"pass REPORT_FAILED=${SPACEOPT_REPORT_FAILED:-0} $*\"\n" + snakemake_body)
    fake.chmod(0o755)
    time.sleep(0.01)
    (root / ".venv" / ".installed").touch()
    return root


@pytest.mark.parametrize("failure, passes, rc", [
    ("mkdir -p results/perturbed/e8 && echo '{}' > results/perturbed/e8/j2_n450.failure.json; exit 1", 2, 1),
    ("exit 1", 1, 1),                       # a failure elsewhere (no perturbed diagnosis): no report pass
    ("exit 0", 1, 0),
])
def test_dev_reproduce_builds_the_report_without_failed_perturbed_solves_and_keeps_the_exit_status(
        tmp_path, failure, passes, rc):
    """./dev reproduce: when the first pass wrote a perturbed *.failure.json, a second pass runs
    with SPACEOPT_REPORT_FAILED=1 and the same arguments (spaceopt.studies.failed_solves); the
    exit status is the first pass's."""
    root = _dev_tree(tmp_path, f'[ "${{SPACEOPT_REPORT_FAILED:-0}}" = 1 ] && exit 0\n{failure}\n')
    proc = subprocess.run(["bash", "dev", "reproduce", "--dry-run"], cwd=root, capture_output=True, text=True,
                          env=dict(os.environ, SPACEOPT_NO_TEX="1"), timeout=60)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("pass ")]
    assert proc.returncode == rc, proc.stdout + proc.stderr
    assert lines[0] == "pass REPORT_FAILED=0 --cores 2 --keep-going --dry-run"
    assert len(lines) == passes
    if passes == 2:
        assert lines[1] == "pass REPORT_FAILED=1 --cores 2 --keep-going --dry-run"
        assert "building the report without them" in proc.stderr
