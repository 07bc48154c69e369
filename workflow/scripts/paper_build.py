"""Build the paper PDF with latexmk (pdflatex) in a fresh build directory, byte-stably.

SOURCE_DATE_EPOCH and FORCE_SOURCE_DATE fix every date pdfTeX writes (CreationDate, ModDate,
\\today, the trailer /ID); the build directory is wiped first so that no stale auxiliary file
changes the result. The results directory reaches the paper as the macro \\resultsdir.

Usage: python workflow/scripts/paper_build.py --tex paper/paper.tex --results RESULTS
           --build BUILD_DIR --out paper.pdf --epoch 1767225600
"""
import argparse
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
    latexmk = shutil.which("latexmk")
    if latexmk is None:
        raise ConfigError("latexmk", None, "not found; install TeX with ./dev setup "
                          "(Debian: latexmk texlive-latex-extra)")
    build = Path(a.build)
    shutil.rmtree(build, ignore_errors=True)
    build.mkdir(parents=True)
    tex = Path(a.tex)
    env = dict(os.environ, SOURCE_DATE_EPOCH=str(a.epoch), FORCE_SOURCE_DATE="1", TZ="UTC",
               max_print_line="1000")
    results = a.results.rstrip("/") or "."
    cmd = [latexmk, "-pdf", "-interaction=nonstopmode", "-halt-on-error", "-file-line-error",
           f"-outdir={build}", f"-usepretex=\\def\\resultsdir{{{results}}}{profile_note(a.note)}", str(tex)]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, errors="replace")
    if proc.returncode == 0:
        # A second latexmk call compares the auxiliary files (.aux, .toc) by content with what the
        # last pass read and reruns pdflatex if they changed; under heavy load the first call once
        # stopped one pass early (stale table of contents, a different PDF). Up to date: no pass.
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, errors="replace")
    sys.stderr.write(proc.stdout[-20000:])
    sys.stderr.write(proc.stderr[-20000:])
    pdf = build / (tex.stem + ".pdf")
    if proc.returncode != 0 or not pdf.exists():
        raise ArtifactError(f"paper={str(tex)!r}: latexmk failed: {first_error(build / (tex.stem + '.log'))}")
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(pdf, a.out)


if __name__ == "__main__":
    run_step(main)
