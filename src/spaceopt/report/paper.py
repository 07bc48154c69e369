"""Generated LaTeX fragments of the paper: study sections list, errata, performance.

The paper (``paper/paper.tex``) is assembled from fragments that the workflow generates under
``results/``; nothing is copied by hand (docs/conventions-paper.md). This module renders:

- ``sections.tex``: one ``\\input`` per study fragment ``results/<study>/paper_section.tex`` that
  the DAG produces, in the order of ``report.paper.section_order`` (unknown studies last,
  alphabetically); a study without a fragment gets an automatic section built from its
  reproduction table, LaTeX tables and figures in ``ALL_TARGETS``;
- ``errata.tex``: the errata of the sources, from ``config/errata.yaml``;
- ``performance.tex``: the benchmark results ``results/benchmarks/*.json``.

Fields of ``config/errata.yaml`` are LaTeX snippets (math in ``$...$``); everything else that
goes into LaTeX from data is escaped with :func:`latex_escape`.
"""
from __future__ import annotations

import json
import math

from pathlib import Path

import yaml

from ..errors import ArtifactError, ConfigError

_LATEX_SPECIAL = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#",
                  "_": r"\_", "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}",
                  "^": r"\textasciicircum{}", "<": r"\textless{}", ">": r"\textgreater{}"}
_UNICODE = {"§": r"\S{}", "°": r"\ensuremath{^\circ}", "−": "-", "–": "--", "—": "---",
            "τ": r"\ensuremath{\tau}", "≤": r"\ensuremath{\le}", "≥": r"\ensuremath{\ge}",
            "×": r"\ensuremath{\times}", "·": r"\ensuremath{\cdot}", "±": r"\ensuremath{\pm}", "µ": r"\ensuremath{\mu}",
            "μ": r"\ensuremath{\mu}", "Δ": r"\ensuremath{\Delta}", "…": r"\ldots{}",
            "’": "'", "“": "``", "”": "''"}


def latex_escape(text) -> str:
    """Escape a plain string for LaTeX text mode (also maps a few common Unicode symbols)."""
    s = "".join(_LATEX_SPECIAL.get(ch, ch) for ch in str(text))
    return "".join(_UNICODE.get(ch, ch) for ch in s)


def latex_number(x: float) -> str:
    """A positive number in LaTeX math: 1e-2 → ``10^{-2}``, 3e-2 → ``3\\cdot10^{-2}``, 0.5 → ``0.5``
    (powers of ten below 0.1 and from 10⁴)."""
    mant, exp = f"{float(x):.6e}".split("e")
    mant, exp = f"{float(mant):g}", int(exp)
    if -1 <= exp <= 3:
        return f"{float(x):g}"
    return (f"{mant}\\cdot" if mant != "1" else "") + f"10^{{{exp}}}"


def breakable(tex: str) -> str:
    """Allow line breaks after the underscores, slashes and commas of identifiers, paths, lists."""
    return tex.replace(r"\_", r"\_\allowbreak{}").replace("/", r"/\allowbreak{}").replace(",", r",\allowbreak{}")


# ----------------------------------------------------------------------------- study sections

def study_of(path, results_dir) -> str:
    """The study a result belongs to: the first folder of ``path`` below ``results_dir``."""
    p = str(path).replace("\\", "/")
    root = str(results_dir).replace("\\", "/").rstrip("/") + "/"
    if not p.startswith(root) or "/" not in p[len(root):]:
        raise ConfigError("paper.path", str(path), f"expected {root}<study>/...")
    return p[len(root):].split("/", 1)[0]


def _rank(study, section_order):
    from fnmatch import fnmatch

    for i, pat in enumerate(section_order):
        if fnmatch(study, pat):
            return (i, study)
    return (len(section_order), study)


def _image_size(path):
    """(width, height) of a PNG in pixels or of a PDF's first MediaBox in points; None if unknown."""
    import re
    import struct

    try:
        with open(path, "rb") as fh:
            head = fh.read(200_000)
    except OSError:
        return None
    if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
        return struct.unpack(">II", head[16:24])
    m = re.search(rb"/MediaBox\s*\[\s*([-\d.]+)\s+([-\d.]+)\s+([-\d.]+)\s+([-\d.]+)\s*\]", head)
    if m:
        x0, y0, x1, y1 = (float(v) for v in m.groups())
        return (x1 - x0, y1 - y0)
    return None


def _is_small(path) -> bool:
    """A figure small and square enough to stand beside another (half the text width)."""
    size = _image_size(path)
    if not size or size[1] <= 0:
        return False
    w, h = size
    limit = 1000 if str(path).endswith(".png") else 480      # pixels at 150 dpi ~ points
    return w <= limit and w / h <= 1.45


def _caption(path, study) -> str:
    name = Path(path).stem.replace("_", " ")
    return (f"\\caption{{Study \\texttt{{{latex_escape(study)}}}: {latex_escape(name)} "
            f"(\\texttt{{{breakable(latex_escape(path))}}}).}}")


def _figure_tex(path, study="") -> str:
    return "\n".join([r"\begin{figure}[htbp]\centering",
                      f"\\includegraphics[width=0.9\\linewidth,height=0.4\\textheight,keepaspectratio]{{{path}}}",
                      _caption(path, study), r"\end{figure}"])


def _figure_pair_tex(a, b, study="") -> str:
    """Two small figures side by side, each with its own caption."""
    out = [r"\begin{figure}[htbp]\centering"]
    for i, path in enumerate((a, b)):
        out += [r"\begin{minipage}[t]{0.48\linewidth}\centering",
                f"\\includegraphics[width=\\linewidth,height=0.3\\textheight,keepaspectratio]{{{path}}}",
                _caption(path, study), r"\end{minipage}" + (r"\hfill" if i == 0 else "")]
    out.append(r"\end{figure}")
    return "\n".join(out)


def _group(path) -> str:
    return Path(path).stem.split("_", 1)[0]


def figures_tex(figures, study="") -> list[str]:
    """Figure floats: consecutive small figures of one group (name prefix) go in pairs."""
    out, pending = [], None
    for f in figures:
        if _is_small(f):
            if pending is not None and _group(pending) == _group(f):
                out.append(_figure_pair_tex(pending, f, study))
                pending = None
                continue
            if pending is not None:
                out.append(_figure_tex(pending, study))
            pending = f
            continue
        if pending is not None:
            out.append(_figure_tex(pending, study))
            pending = None
        out.append(_figure_tex(f, study))
    if pending is not None:
        out.append(_figure_tex(pending, study))
    return out


def auto_section_tex(study, repro=(), tables=(), figures=()) -> str:
    """A section assembled from a study's outputs, for studies without their own fragment."""
    from .scoreboard import gather, summarize

    out = [f"\\section{{Study \\texttt{{{latex_escape(study)}}}}}\\label{{sec:{study}}}",
           r"\noindent\emph{This section was assembled automatically from the study's outputs; "
           r"the study has not provided its own \texttt{paper\_section.tex} yet.}", ""]
    if repro:
        for s in summarize(gather(repro))[:-1]:
            out.append(f"Reproduction (\\texttt{{{latex_escape(s['study'])}}}): {s['total']} published values, "
                       f"{s['pass']} pass, {s['fail']} fail, {s['missing']} missing, {s['info']} for "
                       r"information only; every value is listed in Table~\ref{tab:scoreboard}." + "\n")
    for t in tables:
        out += [f"% table {t}", r"\begin{center}\small", f"\\input{{{t}}}", r"\end{center}"]
    out += figures_tex(figures, study)
    out.append(r"\clearpage")
    return "\n".join(out) + "\n"


def _prefer_pdf(figures) -> list[str]:
    """One file per figure: the PDF when both PDF and PNG are produced."""
    figs = sorted({str(f) for f in figures})
    stems_pdf = {f[:-4] for f in figs if f.endswith(".pdf")}
    return [f for f in figs if not (f.endswith(".png") and f[:-4] in stems_pdf)]


def sections_tex(results_dir, fragments=(), repro=(), tables=(), figures=(), section_order=(),
                 auto_sections=True) -> str:
    """``sections.tex``: each study's own fragment, or an automatic section, in study order."""
    lines = ["% Generated by workflow/scripts/paper_sections.py: one section per study that the",
             "% workflow produces (docs/conventions-paper.md). Do not edit."]
    by_study: dict[str, dict] = {}
    for kind, paths in (("fragment", fragments), ("repro", repro), ("tables", tables),
                        ("figures", _prefer_pdf(figures))):
        for p in sorted({str(p) for p in paths}):
            by_study.setdefault(study_of(p, results_dir), {}).setdefault(kind, []).append(p)
    studies = sorted(by_study, key=lambda s: _rank(s, section_order))
    n = 0
    for study in studies:
        d = by_study[study]
        if d.get("fragment"):
            lines += [f"% study {study}"] + [f"\\input{{{p}}}" for p in d["fragment"]]
            n += 1
        elif auto_sections:
            lines += [f"% study {study} (automatic section)",
                      auto_section_tex(study, d.get("repro", ()), d.get("tables", ()), d.get("figures", ()))]
            n += 1
    if not n:
        lines += [r"\section{Studies}", r"No study has produced results for the paper yet."]
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------- errata

ERRATUM_KEYS = ("id", "kind", "source", "location", "printed", "correct", "evidence", "spec")
KINDS = ("erratum", "ambiguity", "missing")


def load_errata(path) -> list[dict]:
    """Entries of ``config/errata.yaml``, validated (one-line ConfigError naming the key)."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ConfigError(str(path), None, "missing errata file") from None
    except yaml.YAMLError as exc:
        raise ConfigError(str(path), "<yaml>", f"malformed YAML: {str(exc).splitlines()[0]}") from None
    entries = (data or {}).get("errata")
    if not isinstance(entries, list):
        raise ConfigError(f"{path.name}:errata", entries, "expected a list of entries")
    seen = set()
    for i, e in enumerate(entries):
        for key in ("id", "kind", "source", "location", "correct", "evidence", "spec"):
            if not e.get(key):
                raise ConfigError(f"{path.name}:errata[{i}].{key}", e.get(key), "missing")
        if e["kind"] not in KINDS:
            raise ConfigError(f"{path.name}:errata[{i}].kind", e["kind"], f"expected one of {KINDS}")
        if e["id"] in seen:
            raise ConfigError(f"{path.name}:errata[{i}].id", e["id"], "duplicate id")
        seen.add(e["id"])
    return entries


def errata_tex(entries: list[dict]) -> str:
    """The errata as a LaTeX list grouped by kind (fields are LaTeX snippets)."""
    titles = {"erratum": "Errata (the printed text is wrong)",
              "ambiguity": "Ambiguities (the text admits several readings; our choice)",
              "missing": "Missing data (not stated in the source; our choice)"}
    out = ["% Generated by workflow/scripts/paper_errata.py from config/errata.yaml. Do not edit."]
    counts = {k: sum(e["kind"] == k for e in entries) for k in KINDS}
    out.append(f"The sources contain {counts['erratum']} errata, {counts['ambiguity']} ambiguities "
               f"and {counts['missing']} items of missing data that a reproduction has to resolve. "
               r"Each entry names where it occurs, what is printed, what we use instead, the "
               r"evidence, and the paragraph of the specification that records it.")
    for kind in KINDS:
        group = [e for e in entries if e["kind"] == kind]
        if not group:
            continue
        out += ["", f"\\subsection*{{{titles[kind]}}}", r"\begin{enumerate}\small\setlength{\emergencystretch}{3em}"]
        for e in group:
            item = [f"\\item[\\textbf{{{latex_escape(e['id'])}}}] \\textit{{{e['source']}, {e['location']}.}}"]
            if e.get("printed"):
                item.append(f"Printed: {e['printed']}.")
            item.append(f"{'Correct' if kind == 'erratum' else 'We use'}: {e['correct']}.")
            item.append(f"Evidence: {e['evidence']}.")
            item.append(f"(Specification: \\texttt{{{latex_escape(e['spec'])}}}.)")
            out.append(" ".join(item))
        out.append(r"\end{enumerate}")
    return "\n".join(out) + "\n"


def errata_markdown(entries: list[dict]) -> str:
    """The errata as a Markdown table (fields stay LaTeX snippets) for the HTML report."""
    out = ["| id | kind | where | printed | correct / we use | evidence | specification |",
           "|---|---|---|---|---|---|---|"]
    cell = lambda x: str(x or "").replace("|", "\\|").replace("\n", " ")  # noqa: E731
    for e in entries:
        out.append("| " + " | ".join(cell(e.get(k)) for k in ("id", "kind")) + " | "
                   + cell(f"{e['source']}, {e['location']}") + " | "
                   + " | ".join(cell(e.get(k)) for k in ("printed", "correct", "evidence", "spec")) + " |")
    return "\n".join(out) + "\n"


# ----------------------------------------------------------------------------- performance

_TIME_KEYS = ("median_wall_s", "median_s", "warm_wall_s", "warm_time_s", "wall_s", "wall_time_s", "mean_s",
              "time_s", "min_wall_s", "min_s")
_COMPILE_KEYS = ("compile_s", "compile_time_s", "compile_overhead_s")
_SKIP_KEYS = {"provenance", "machine", "host", "summary", "units", "note", "suite", "stderr_tail"}
_MAX_DETAILS = 6


def load_benchmark(path) -> dict:
    path = Path(path)
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise ArtifactError(f"artifact={str(path)!r}: missing") from None
    except json.JSONDecodeError as exc:
        raise ArtifactError(f"artifact={str(path)!r}: corrupted or truncated JSON ({exc.msg})") from None


def _time_of(d: dict):
    return next((d[k] for k in _TIME_KEYS if isinstance(d.get(k), (int, float)) and not isinstance(d.get(k), bool)),
                None)


def benchmark_rows(path) -> list[dict]:
    """Rows ``{suite, name, time_s, compile_s, details}`` of one benchmark JSON.

    Every mapping in the file that holds a time (the first of ``median_wall_s``, ``median_s``,
    ``wall_s``, ``wall_time_s``, ``mean_s``, ``time_s``, ``min_wall_s``, ``min_s``) becomes a row
    named by its path of keys (or its ``name``); ``compile_s`` is shown separately and other
    scalars are details. Lists of such mappings (``{"results": [{"name": ..., ...}]}``) and flat
    ``{case: seconds}`` mappings work too (docs/conventions-paper.md). ``provenance``,
    ``machine`` and ``summary`` blocks are not rows.
    """
    data = load_benchmark(path)
    suite = str(data.get("suite", Path(path).stem)) if isinstance(data, dict) else Path(path).stem
    rows: list[dict] = []

    def walk(node, name):
        if isinstance(node, dict):
            t = _time_of(node)
            if t is not None:
                used = {"name", *_COMPILE_KEYS, *_TIME_KEYS}
                details = [f"{k}={_short(v)}" for k, v in sorted(node.items())
                           if k not in used and k not in _SKIP_KEYS
                           and isinstance(v, (int, float, str, bool)) and len(str(v)) <= 40]
                rows.append({"suite": suite, "name": str(node.get("name", name or "total")), "time_s": t,
                             "compile_s": next((node[k] for k in _COMPILE_KEYS
                                                if isinstance(node.get(k), (int, float))
                                                and not isinstance(node.get(k), bool)), None),
                             "details": ", ".join(details[:_MAX_DETAILS])})
            if t is None and not name and _flat(node):          # top level {case: seconds}
                for k, v in node.items():
                    if k not in _SKIP_KEYS:
                        rows.append({"suite": suite, "name": f"{name}/{k}" if name else k, "time_s": v,
                                     "compile_s": None, "details": ""})
                return
            for k, v in node.items():
                if k not in _SKIP_KEYS and isinstance(v, (dict, list)):
                    walk(v, f"{name}/{k}" if name else k)
        elif isinstance(node, list):
            for i, v in enumerate(node):
                if isinstance(v, (dict, list)):
                    walk(v, f"{name}[{i}]")

    walk(data, "")
    return rows


def collapse_rows(rows: list[dict]) -> list[dict]:
    """One row per list of timed runs: ``cells[0]``, ``cells[1]``, ... become ``cells (N runs)``.

    The row's time is the median of the runs; min, max and total go to the details. Rows keep
    the order of their first member.
    """
    import re
    import statistics

    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["suite"], re.sub(r"\[\d+\]", "[*]", r["name"])), []).append(r)
    out = []
    for (suite, name), members in groups.items():
        if len(members) == 1 or "[*]" not in name:
            out += members
            continue
        times = [float(m["time_s"]) for m in members]
        comp = [float(m["compile_s"]) for m in members if isinstance(m["compile_s"], (int, float))]
        out.append({"suite": suite, "name": f"{name.replace('[*]', '')} ({len(members)} runs)",
                    "time_s": statistics.median(times),
                    "compile_s": statistics.median(comp) if comp else None,
                    "details": f"median of {len(members)} runs; min {_fmt_s(min(times))}, "
                               f"max {_fmt_s(max(times))}, total {_fmt_s(sum(times))}"})
    return out


def _flat(node: dict) -> bool:
    """A flat ``{case: seconds}`` mapping: only numbers (besides skipped blocks)."""
    vals = [v for k, v in node.items() if k not in _SKIP_KEYS]
    return bool(vals) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals)


def _short(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_short(x) for x in v) + "]"
    return str(v)


def _fmt_s(x) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)) or x < 0:     # < 0: cold - warm of a shared cache
        return "--"
    return f"{x:.3g}"


def machine_of(path) -> str:
    data = load_benchmark(path)
    m = data.get("machine") or data.get("host") if isinstance(data, dict) else None
    if isinstance(m, dict):
        return ", ".join(f"{k}: {_short(v)}" for k, v in sorted(m.items()))
    return str(m) if m else ""


def performance_tex(paths) -> str:
    out = ["% Generated by workflow/scripts/paper_performance.py from results/benchmarks/*.json.",
           "% Do not edit."]
    paths = sorted({str(p) for p in paths})
    rows = collapse_rows([r for p in paths for r in benchmark_rows(p)])
    if not rows:
        out.append(r"No benchmark results yet: run the harnesses in \texttt{benchmarks/} "
                   r"(they write \texttt{results/benchmarks/*.json}).")
        return "\n".join(out) + "\n"
    head = r"suite & case & time, s & compile, s & details \\"
    out += [r"{\footnotesize\setlength{\tabcolsep}{3pt}",
            r"\begin{longtable}{@{}>{\raggedright\arraybackslash}p{0.1\linewidth}>{\raggedright\arraybackslash}p{0.3\linewidth}"
            r">{\raggedleft\arraybackslash}p{0.07\linewidth}>{\raggedleft\arraybackslash}p{0.08\linewidth}"
            r">{\raggedright\arraybackslash}p{0.39\linewidth}@{}}",
            r"\caption{Benchmark results (wall-clock seconds; compile time of JAX kernels separately "
            r"where the harness measures it; repeated runs of one kind are summarised by their median).}"
            r"\label{tab:performance}\\",
            r"\toprule " + head + r" \midrule\endfirsthead",
            r"\multicolumn{5}{@{}l}{\small\tablename~\thetable{} (continued)}\\",
            r"\toprule " + head + r" \midrule\endhead",
            r"\bottomrule\endfoot"]
    suite = None
    for r in rows:
        first = r["suite"] != suite
        if first and suite is not None:
            out.append(r"\midrule")
        suite = r["suite"]
        out.append(" & ".join([breakable(latex_escape(r["suite"])) if first else "",
                               breakable(latex_escape(r["name"])),
                               _fmt_s(r["time_s"]), _fmt_s(r["compile_s"]),
                               breakable(latex_escape(r["details"]))]) + r" \\")
    out += [r"\end{longtable}}"]
    machines = sorted({(Path(p).stem, machine_of(p)) for p in paths if machine_of(p)})
    if machines:
        out.append(r"\noindent{\footnotesize Machines: " + "; ".join(
            f"\\texttt{{{latex_escape(s)}}}: {latex_escape(m)}" for s, m in machines) + ".}")
    return "\n".join(out) + "\n"


def performance_markdown(paths) -> str:
    rows = collapse_rows([r for p in sorted({str(p) for p in paths}) for r in benchmark_rows(p)])
    out = ["| suite | case | time, s | compile, s | details |", "|---|---|---:|---:|---|"]
    cell = lambda x: str(x).replace("|", "\\|")  # noqa: E731
    out += [f"| {cell(r['suite'])} | {cell(r['name'])} | {_fmt_s(r['time_s'])} | {_fmt_s(r['compile_s'])} | "
            f"{cell(r['details'])} |" for r in rows]
    return "\n".join(out) + "\n"
