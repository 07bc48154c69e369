"""The reproduction scoreboard: every study's reproduction table in one place.

Each study writes its rows of the reproduction table to ``results/<study>/reproduction*.csv``
with the columns of :data:`spaceopt.report.compare.COLUMNS` (design.md, principle 4). The
scoreboard concatenates those tables (every published value beside ours, with relative
difference, tolerance and pass/fail) and adds one summary line per study counting the rows by
status::

    status in {pass, fail, missing, info}

``missing`` means the study has not produced our number yet; ``info`` means the published value
is reported without a tolerance (a qualitative or "report only" entry). Any other status found
in a table is counted under ``other`` so that nothing is dropped silently.

Outputs are CSV (machine-readable), Markdown and LaTeX (a ``longtable`` fragment for the paper).
"""
from __future__ import annotations

import csv
import math
from pathlib import Path

from ..errors import ArtifactError
from .compare import COLUMNS
from .paper import breakable, latex_escape

STATUSES = ("pass", "fail", "missing", "info")
SUMMARY_COLUMNS = ["study", "total", *STATUSES, "other"]


def read_table(path) -> list[dict]:
    """Rows of one reproduction CSV; raises ArtifactError when it lacks a required column."""
    path = Path(path)
    try:
        with open(path, newline="") as fh:
            reader = csv.DictReader(fh)
            header = reader.fieldnames or []
            missing = [c for c in COLUMNS if c not in header]
            if missing:
                raise ArtifactError(f"artifact={str(path)!r}: reproduction table lacks columns {missing}")
            rows = [{c: (r.get(c) or "") for c in COLUMNS} for r in reader]
    except FileNotFoundError:
        raise ArtifactError(f"artifact={str(path)!r}: missing") from None
    except (csv.Error, UnicodeDecodeError) as exc:
        raise ArtifactError(f"artifact={str(path)!r}: unreadable CSV ({exc})") from None
    for i, r in enumerate(rows):
        if not r["study"]:
            raise ArtifactError(f"artifact={str(path)!r}: row {i + 1} has an empty 'study'")
    return rows


def gather(paths) -> list[dict]:
    """All rows of all tables, in a stable order (study, then file order within a study)."""
    rows = []
    for p in sorted({str(p) for p in paths}):
        rows += read_table(p)
    order = {s: i for i, s in enumerate(sorted({r["study"] for r in rows}))}
    return sorted(rows, key=lambda r: order[r["study"]])   # stable: keeps file order in a study


def summarize(rows: list[dict]) -> list[dict]:
    """One line per study with counts per status, plus a final ``all`` line."""
    out = {}
    for r in rows:
        s = out.setdefault(r["study"], {c: 0 for c in SUMMARY_COLUMNS[1:]})
        s["total"] += 1
        s[r["status"] if r["status"] in STATUSES else "other"] += 1
    lines = [{"study": k, **v} for k, v in sorted(out.items())]
    total = {c: sum(line[c] for line in lines) for c in SUMMARY_COLUMNS[1:]}
    return lines + [{"study": "all", **total}]


# ----------------------------------------------------------------------------- formatting

def _number_or_text(text):
    """float(text), or the text itself ('' for an empty cell) when it is not a number."""
    if text in ("", None):
        return ""
    try:
        return float(text)
    except ValueError:
        return str(text)


def fmt_number(text: str, digits: int = 10) -> str:
    """A CSV number as a short human string (``repr`` floats are long); text passes through."""
    x = _number_or_text(text)
    if isinstance(x, str):
        return x
    if math.isnan(x) or math.isinf(x):
        return str(x)
    if float(x).is_integer() and abs(x) < 1e15 and "e" not in str(text).lower() and "." not in str(text):
        return str(int(x))
    return f"{x:.{digits}g}"


def sig_digits(text: str) -> int | None:
    """Significant digits of a number as printed (``"0.0012300"`` -> 5); None for text."""
    t = str(text).strip().lower().lstrip("+-")
    try:
        float(t)
    except ValueError:
        return None
    mant = t.split("e")[0].replace(".", "").lstrip("0")
    return max(len(mant), 1)


def fmt_published(text: str) -> str:
    """A published value as printed in the source (stored as data); long floats are shortened."""
    t = str(text)
    return t if len(t) <= 12 else fmt_number(t)


def fmt_ours(text: str, published: str = "") -> str:
    """Our value with one significant digit more than the published one (6 to 10 in all)."""
    n = sig_digits(published)
    return fmt_number(text, min(10, max(6, (n or 6) + 1)))


def fmt_rel(text: str) -> str:
    x = _number_or_text(text)
    if isinstance(x, str):
        return x
    return f"{x:.2e}" if math.isfinite(x) else "--"        # published 0: no relative difference


DISPLAY = [("case", "case"), ("quantity", "quantity"), ("unit", "unit"), ("published", "published"),
           ("ours", "ours"), ("rel_diff", "rel. diff."), ("tolerance", "tolerance"),
           ("status", "status"), ("ref", "ref")]


def _display_row(r: dict) -> dict:
    d = dict(r)
    d["published"], d["ours"] = fmt_published(r["published"]), fmt_ours(r["ours"], r["published"])
    d["rel_diff"] = fmt_rel(r["rel_diff"])
    return d


def _md_cell(x) -> str:
    return str(x).replace("|", "\\|").replace("\n", " ")


def to_markdown(rows: list[dict], summary: list[dict]) -> str:
    out = ["# Reproduction scoreboard", "",
           "Every published value beside ours (generated; do not edit).", "",
           "## Summary per study", "",
           "| " + " | ".join(SUMMARY_COLUMNS) + " |",
           "|" + "|".join("---" if c == "study" else "---:" for c in SUMMARY_COLUMNS) + "|"]
    out += ["| " + " | ".join(_md_cell(s[c]) for c in SUMMARY_COLUMNS) + " |" for s in summary]
    out += ["", "## All values", ""]
    for study in sorted({r["study"] for r in rows}):
        out += [f"### {study}", "", "| " + " | ".join(h for _, h in DISPLAY) + " | note |",
                "|" + "|".join("---" for _ in range(len(DISPLAY) + 1)) + "|"]
        for r in rows:
            if r["study"] == study:
                d = _display_row(r)
                out.append("| " + " | ".join(_md_cell(d[k]) for k, _ in DISPLAY) + f" | {_md_cell(r['note'])} |")
        out.append("")
    if not rows:
        out += ["No study has produced a reproduction table yet.", ""]
    return "\n".join(out)


_STATUS_TEX = {"pass": r"\textsf{pass}", "fail": r"\textbf{\textsf{FAIL}}",
               "missing": r"\textit{missing}", "info": r"\textsf{info}"}


def to_latex(rows: list[dict], summary: list[dict]) -> str:
    """A LaTeX fragment: a summary table and one ``longtable`` with every value, then its notes.

    Needs ``booktabs``, ``longtable`` and ``array`` in the preamble.
    """
    e = latex_escape
    cols = [c for c in SUMMARY_COLUMNS if c != "other" or any(s["other"] for s in summary)]
    out = ["% Generated by workflow/scripts/scoreboard.py; do not edit.",
           r"\begin{table}[htbp]\centering\small",
           r"\caption{Reproduction summary: number of published values per study by status.}",
           r"\label{tab:scoreboard-summary}",
           r"\begin{tabular}{l" + "r" * (len(cols) - 1) + "}", r"\toprule",
           " & ".join(e(c) for c in cols) + r" \\", r"\midrule"]
    for s in summary:
        if s["study"] == "all":
            out.append(r"\midrule")
        out.append(" & ".join(e(str(s[c])) for c in cols) + r" \\")
    out += [r"\bottomrule", r"\end{tabular}", r"\end{table}", ""]
    if not rows:
        out.append(r"\noindent No study has produced a reproduction table yet.")
        return "\n".join(out) + "\n"
    out.append(rows_longtable(rows, r"Every published value beside ours. rel.\ diff.\ = (ours $-$ "
                              r"published)/$|$published$|$; the case and the source are printed where they "
                              r"change; n.\ refers to the notes below the table.",
                              "tab:scoreboard"))
    return "\n".join(out)


# Column layout of the longtable: fixed widths (fractions of \linewidth) so that long values
# wrap inside their cell instead of widening the table. Notes go below the table, numbered.
_LT_COLS = [("case", 0.115, "l"), ("quantity", 0.13, "l"), ("unit", 0.055, "l"), ("published", 0.11, "r"),
            ("ours", 0.11, "r"), ("rel_diff", 0.075, "r"), ("tolerance", 0.075, "l"), ("status", 0.055, "l"),
            ("ref", 0.145, "l")]
_LT_NOTE = 0.025


def _cell(d: dict, k: str) -> str:
    if k == "status":
        return _STATUS_TEX.get(d[k], latex_escape(d[k]))
    if k == "published" and d[k] == "held back":
        return r"\textit{held back}"
    if k in ("published", "ours", "rel_diff") and sig_digits(d[k]) is not None:
        return r"\mbox{" + latex_escape(d[k]) + "}"          # a number never breaks at its minus sign
    return breakable(latex_escape(d[k]))


def rows_longtable(rows: list[dict], caption: str, label: str, show_study: bool = True) -> str:
    """Reproduction rows as a ``longtable`` and its numbered notes (caption is LaTeX).

    Needs booktabs, longtable and array. A case or source equal to the one of the row above (same
    study) is left blank; identical notes share one number.
    """
    e = latex_escape
    align = {"l": r"\raggedright", "r": r"\raggedleft"}
    spec = "@{}" + "".join(f">{{{align[a]}\\arraybackslash}}p{{{w}\\linewidth}}" for _, w, a in _LT_COLS) \
        + f">{{\\raggedleft\\arraybackslash}}p{{{_LT_NOTE}\\linewidth}}@{{}}"
    titles = dict(DISPLAY, ref="source")
    head = " & ".join(e(titles[k]) for k, _, _ in _LT_COLS) + r" & n. \\"
    ncol = len(_LT_COLS) + 1
    out = [r"{\scriptsize\setlength{\tabcolsep}{2pt}",
           f"\\begin{{longtable}}{{{spec}}}",
           f"\\caption{{{caption}}}\\label{{{label}}}\\\\",
           r"\toprule", head, r"\midrule", r"\endfirsthead",
           r"\multicolumn{" + str(ncol) + r"}{@{}l}{\small\tablename~\thetable{} (continued)}\\",
           r"\toprule", head, r"\midrule", r"\endhead",
           r"\bottomrule", r"\endfoot"]
    notes: dict[str, int] = {}
    note_study: dict[int, str] = {}
    current, prev = None, {}
    for r in rows:
        if r["study"] != current:
            current, prev = r["study"], {}
            if show_study:
                if out[-1].endswith(r"\\"):
                    out.append(r"\addlinespace[2pt]")
                out.append(r"\multicolumn{" + str(ncol) + r"}{@{}l}{\small\textbf{" + e(current) + r"}} \\[1pt]")
        d = _display_row(r)
        cells = [_cell(d, k) for k, _, _ in _LT_COLS]
        if prev.get("case") == d["case"]:        # a new case prints its source again
            cells[0] = ""
            if prev.get("ref") == d["ref"]:
                cells[-1] = ""
        prev = {"case": d["case"], "ref": d["ref"]}
        mark = ""
        if r["note"]:
            if r["note"] not in notes:
                notes[r["note"]] = len(notes) + 1
                note_study[notes[r["note"]]] = r["study"]
            mark = str(notes[r["note"]])
        out.append(" & ".join(cells) + " & " + mark + r" \\")
    out += [r"\end{longtable}}", ""]
    if notes:
        out += [r"{\footnotesize\noindent\textbf{Notes to Table~\ref{" + label + r"}.}",
                r"\begin{list}{}{\setlength{\leftmargin}{2.2em}\setlength{\labelwidth}{1.8em}"
                r"\setlength{\labelsep}{0.4em}\setlength{\itemsep}{0pt}\setlength{\parsep}{0pt}"
                r"\setlength{\topsep}{2pt}}"]
        current = None
        for text, n in notes.items():
            if show_study and note_study[n] != current:
                current = note_study[n]
                out.append(r"\item[] \textit{" + e(current) + "}")
            out.append(f"\\item[{n}.] " + breakable(e(text)))
        out += [r"\end{list}}", ""]
    return "\n".join(out)


def write_scoreboard(rows: list[dict], summary: list[dict], csv_path, md_path, tex_path,
                     summary_csv_path=None) -> None:
    """Write the full scoreboard (CSV, Markdown, LaTeX) and optionally the summary CSV."""
    for p in (csv_path, md_path, tex_path, summary_csv_path):
        if p is not None:
            Path(p).parent.mkdir(parents=True, exist_ok=True)
    with open(csv_path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    if summary_csv_path is not None:
        with open(summary_csv_path, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=SUMMARY_COLUMNS, lineterminator="\n")
            w.writeheader()
            w.writerows(summary)
    Path(md_path).write_text(to_markdown(rows, summary) + "\n")
    Path(tex_path).write_text(to_latex(rows, summary))


def build(tables, csv_path, md_path, tex_path, summary_csv_path=None) -> list[dict]:
    """Gather ``tables`` and write the scoreboard; returns the summary lines."""
    rows = gather(tables)
    summary = summarize(rows)
    write_scoreboard(rows, summary, csv_path, md_path, tex_path, summary_csv_path)
    return summary
