"""Build the paper PDF with pdflatex in a fresh build directory, byte-stably.

SOURCE_DATE_EPOCH and FORCE_SOURCE_DATE fix every date pdfTeX writes (CreationDate, ModDate,
\\today, the trailer /ID); the build directory is wiped first so that no stale auxiliary file
changes the result. The results directory reaches the paper as the macro \\resultsdir.

The passes are driven here rather than by latexmk: pdflatex runs until the auxiliary files it
writes (.aux, .toc, .out, ...) are byte-identical to the ones its pass read, so the number of
passes depends on file contents only. latexmk's rerun decision also looks at file times, and
under heavy load (CI, 2 busy cores) it twice produced a PDF one pass behind the other build.

Usage: python workflow/scripts/paper_build.py --tex paper/paper.tex --results RESULTS
           --build BUILD_DIR --out paper.pdf --epoch 1767225600
"""
import argparse
import hashlib
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt.errors import ArtifactError, ConfigError  # noqa: E402
from spaceopt.report.paper import latex_escape  # noqa: E402

AUX_SUFFIXES = (".aux", ".toc", ".out", ".lof", ".lot")
MAX_PASSES = 6


def first_error(log_path: Path) -> str:
    """The first LaTeX error of a .log file, as one line."""
    try:
        text = log_path.read_text(errors="replace")
    except FileNotFoundError:
        return "no log written"
    for line in text.splitlines():
        if line.startswith("!") or re.match(r"^[^:\s]+\.tex:\d+: ", line):
            return line.strip()
    return "see the log"


def auxiliary_digest(build: Path) -> str:
    """One hash over the auxiliary files of a build directory, the input of the next pass."""
    h = hashlib.sha256()
    for f in sorted(build.iterdir()):
        if f.suffix in AUX_SUFFIXES:
            h.update(f.name.encode() + b"\0" + f.read_bytes())
    return h.hexdigest()


def profile_note(note: str) -> str:
    """``\\def\\profilenote{...}`` for a non-empty note (LaTeX-escaped), else nothing."""
    return f"\\def\\profilenote{{{latex_escape(note)}}}" if note.strip() else ""


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tex", required=True)
    ap.add_argument("--results", required=True)
    ap.add_argument("--build", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--epoch", type=int, required=True)
    ap.add_argument("--note", default="", help="profile note printed under the title (plain text)")
    a = ap.parse_args(argv)
    pdflatex = shutil.which("pdflatex")
    if pdflatex is None:
        raise ConfigError("pdflatex", None, "not found; install TeX with ./dev setup "
                          "(Debian: texlive-latex-extra)")
    build = Path(a.build)
    shutil.rmtree(build, ignore_errors=True)
    build.mkdir(parents=True)
    tex = Path(a.tex)
    env = dict(os.environ, SOURCE_DATE_EPOCH=str(a.epoch), FORCE_SOURCE_DATE="1", TZ="UTC",
               max_print_line="1000")
    results = a.results.rstrip("/") or "."
    pretex = f"\\def\\resultsdir{{{results}}}{profile_note(a.note)}\\input{{{tex.as_posix()}}}"
    cmd = [pdflatex, "-interaction=nonstopmode", "-halt-on-error", "-file-line-error",
           f"-output-directory={build.resolve()}", f"-jobname={tex.stem}", pretex]
    log, pdf = build / (tex.stem + ".log"), build / (tex.stem + ".pdf")
    digest = auxiliary_digest(build)
    for n_pass in range(1, MAX_PASSES + 1):
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, errors="replace")
        if proc.returncode != 0:
            sys.stderr.write(proc.stdout[-20000:])
            raise ArtifactError(f"paper={str(tex)!r}: pdflatex pass {n_pass} failed: {first_error(log)}")
        digest, previous = auxiliary_digest(build), digest
        if digest == previous:
            break
    else:
        raise ArtifactError(f"paper={str(tex)!r}: the auxiliary files still changed after {MAX_PASSES} "
                            f"pdflatex passes (see {log})")
    sys.stderr.write(f"pdflatex: {n_pass} passes, auxiliary files converged\n")
    if not pdf.exists():
        raise ArtifactError(f"paper={str(tex)!r}: pdflatex wrote no PDF: {first_error(log)}")
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(pdf, a.out)


if __name__ == "__main__":
    run_step(main)
