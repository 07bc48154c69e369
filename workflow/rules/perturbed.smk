# Dissertation §4.2: perturbed multi-revolution transfers E5-E9 (spec 02-multirev §4-§6).
#   results/perturbed/<case>/<model>.{json,npz,rrd}     E5, E7, E9 chain solves
#   results/perturbed/e6/<date>.{json,npz,rrd}          E6 departure scan (each date from the unperturbed OT)
#   results/perturbed/e6_links/<from>_to_<to>.json      E6 date a's extremal continued to its neighbour b
#   results/perturbed/e6_families.csv                   which neighbouring dates lie on one family
#   results/perturbed/e6_walks/<from>_to_<to>.json      a link's other extremal followed on past its date
#   results/perturbed/e6_{walks,envelope}.csv           the walks' steps; the heaviest extremal found per date
#   results/perturbed/e8/<model>_n<n>.{json,npz,rrd}    E8 (n to n; perturbed from unperturbed at n)
#   results/perturbed/e9_budget.json                    ΔΩ budget check (spec §6)
#   results/perturbed/{e5,e6_date_scan,e7,e8,e9}.csv, reproduction.csv, paper_section.tex, figures/
#   results/perturbed/tof_maximum.csv                   the free-time end game of every perturbed solve
#   results/perturbed/<case>/tmin_<model>.{json,...}    the minimum-thrust existence check per force model
#   results/perturbed/existence.csv                     its table (E5, E7, E9)
#   results/perturbed/<case>/family_<model>.{json,...}  the minimum-fuel family followed down in the thrust
#   results/perturbed/thrust_family.csv                 its points (E7)
import os
from spaceopt.studies.failed_solves import diagnosis, failures_sentence, left_out, without_failed
# the planning module imports no solver: every Snakemake run parses this file
from spaceopt.studies.perturbed_config import (case_start_model, case_start_models, e8_count_start, e8_model_steps,
                                               e8_runs, e8_skipped, e8_smoothing, existence_bound_from,
                                               existence_from_ot, existence_runs, link_pairs, link_settings,
                                               scan_dates, scan_run_dates, scan_source, start_pairs, walk_dates,
                                               walk_settings)
from spaceopt.studies.thrust_family import settings as thrust_family_settings

check_section("perturbed", physical=lambda pc: (scan_run_dates(pc), e8_runs(pc), existence_runs(pc),
                                                existence_bound_from(pc), case_start_models(pc),
                                                thrust_family_settings(pc)))
PT = config["perturbed"]
PTDIR = f"{RESULTS}/perturbed"
PT_SRC = lib_sources("indirect", "elements", "constants", "forces", "ephemeris", "frames", "artifacts",
                     "studies/perturbed", "studies/perturbed_config", "studies/multirev", "studies/multirev_config",
                     "studies/trajectory")


def _pt_fmt(x):
    return f"{float(x):g}"


def pt_files(stem):
    return [f"{PTDIR}/{stem}.{ext}" for ext in ("json", "npz", "rrd")]


def pt_model_has_bodies(model):
    m = PT["models"][model]
    return bool(m) and bool(m.get("third_bodies"))


def pt_ephemeris(case, model):
    """The ephemeris window JSON a solve reads (only models with third bodies need one)."""
    if not pt_model_has_bodies(model):
        return []
    return [f"{RESULTS}/ephemeris/{PT['cases'][case]['ephemeris']}.json"]


def pt_config_for(case, model):
    """Only what a (case, model) solve depends on (not the threads it runs on: PT_THREADS)."""
    cc = PT["cases"][case]
    return {"constants": PT["constants"],
            "numerics": {k: v for k, v in PT["numerics"].items() if k != "jacobian_threads"},
            "models": {model: PT["models"][model]},
            "orbits": {cc[k]: PT["orbits"][cc[k]] for k in ("initial", "final")},
            "cases": {case: cc}}


def pt_warm_source(case, model, n_rev=None):
    """The first model of a case's list is solved by the chain from the zero guess; every later
    model too when the case says model_start: chain (E5, E7), else by a warm start from the
    previous model, or the one the case's model_from names, for every E8 count or at n_rev
    (studies.perturbed_config.case_start_model; warm_start: the force-model blend, its fallbacks):
    E8 unperturbed -> J2 -> 4x4 -> 4x4 + Moon + Sun (at 450 the full model from J2; the exact
    profile: from J2 at every count), E9 J2 -> 4x4 -> 4x4 + Moon + Sun."""
    return case_start_model(PT, case, model, n_rev)


def pt_fallback_source(case, model):
    """With model_start: chain and fallback: previous (E5), a chain that does not converge is
    followed by a warm start from the previous model (reported as such in the artifact)."""
    cc = PT["cases"][case]
    models = cc["models"]
    if model == models[0] or cc.get("model_start", "previous") != "chain" or cc.get("fallback") != "previous":
        return None
    return models[models.index(model) - 1]


# threads per solve: a Jacobian's sensitivity columns split over them (numerics.jacobian_threads;
# spaceopt.indirect.column_threads). 1 by default: the 2-core reproduction runs two solves at once
PT_THREADS = PT["numerics"].get("jacobian_threads", 1)


def pt_solve_inputs(w):
    src = pt_warm_source(w.case, w.model) or pt_fallback_source(w.case, w.model)
    out = {"src": PT_SRC, "eph": pt_ephemeris(w.case, w.model)}
    if src is not None:
        out["start"] = f"{PTDIR}/{w.case}/{src}.json"
    return out


rule perturbed_solve:
    input: unpack(pt_solve_inputs)
    output: pt_files("{case}/{model}")
    wildcard_constraints: case="e5|e7|e9", model="|".join(sorted(PT["models"]))   # not <model>.verify
    params: cfg=lambda w: pt_config_for(w.case, w.model), case="{case}", model="{model}",
            source=lambda w: pt_warm_source(w.case, w.model) or "chain", results=RESULTS
    log: f"{PTDIR}/logs/{{case}}_{{model}}.log"
    benchmark: f"{PTDIR}/benchmarks/{{case}}_{{model}}.tsv"
    resources: mem_mb=4000, runtime=120
    threads: PT_THREADS
    script: "../scripts/perturbed_solve.py"


def pt_e8_start(model, n):
    """What E8 solve (model, n) starts from, as (model, n), or None for a chain from the zero
    guess. The first model of the case: the chain (perturbed.e8.count_start: chain, the
    default), or the next smaller n of the list (previous: n to n, the smallest n the chain).
    Every later model: the previous model at the same n, or the one model_from names for it
    (perturbations switched on by τ; pt_warm_source), so the perturbed counts are independent jobs."""
    prev = pt_warm_source("e8", model, float(n))
    if prev is not None:
        return prev, float(n)
    if e8_count_start(PT) == "chain":
        return None
    ns = sorted(float(x) for x in PT["e8"]["n_rev"])
    n = float(n)
    if n not in ns or ns.index(n) == 0:
        return None
    return model, ns[ns.index(n) - 1]


def pt_e8_source(n, model):
    """The stem of the E8 artifact solve (model, n) starts from (pt_e8_start), or None."""
    start = pt_e8_start(model, n)
    return None if start is None else f"{start[0]}_n{_pt_fmt(start[1])}"


# The second pass of ./dev reproduce (environment SPACEOPT_REPORT_FAILED=1) leaves out the E6 dates,
# the E8 solves (and, below, the minimum-thrust solves and the carried families) that failed in the first, with the solves
# that start from them, so that the tables, figures and paper are built from what converged
# (spaceopt.studies.failed_solves).
REPORT_FAILED = os.environ.get("SPACEOPT_REPORT_FAILED") == "1"
PT_FAILED = {"e6": {}, "e8": {}, "existence": {}, "family": {}}
if REPORT_FAILED:
    _scan_days = {d[:10] for d in scan_dates(PT["e6"])}
    PT_FAILED |= {
        "e6": left_out(scan_run_dates(PT), lambda d: s if (s := scan_source(PT, d)) in _scan_days else None,
                       lambda d: diagnosis(f"{PTDIR}/e6/{d}.json")) if "e6" in PT["run"] else {},
        "e8": left_out(e8_runs(PT), lambda r: pt_e8_start(*r),
                       lambda r: diagnosis(f"{PTDIR}/e8/{r[0]}_n{_pt_fmt(r[1])}.json"),
                       name=lambda r: f"{r[0]} at {r[1]:g} revolutions") if "e8" in PT["run"] else {}}
    PT = without_failed(PT, PT_FAILED["e6"], PT_FAILED["e8"])


# ---------------------------------------------------------------- E6 departure scan

E6 = PT["e6"]
E6_DATES = scan_run_dates(PT)           # checked once by check_section above (skip_dates left out)


def pt_e6_source(date):
    """What a date warm-starts from (spaceopt.studies.perturbed_config.scan_source)."""
    return scan_source(PT, date)


def pt_e6_inputs(w):
    src = pt_e6_source(w.date)
    start = {None: f"{PTDIR}/{E6['case']}/{E6['model']}.json",
             "unperturbed": f"{PTDIR}/{E6['case']}/unperturbed.json"}.get(src, f"{PTDIR}/e6/{src}.json")
    return {"start": start, "src": PT_SRC, "eph": pt_ephemeris(E6["case"], E6["model"])}


rule perturbed_e6_date:
    input: unpack(pt_e6_inputs)
    output: pt_files("e6/{date}")
    wildcard_constraints: date=r"\d{4}-\d{2}-\d{2}"
    params: cfg=lambda w: pt_config_for(E6["case"], E6["model"]), case=E6["case"], model=E6["model"],
            epoch=lambda w: f"{w.date}T{E6.get('time_utc', '12:00:00')}",
            source=lambda w: pt_e6_source(w.date) or "e5", results=RESULTS
    log: f"{PTDIR}/logs/e6_{{date}}.log"
    benchmark: f"{PTDIR}/benchmarks/e6_{{date}}.tsv"
    resources: mem_mb=4000, runtime=60
    threads: PT_THREADS
    script: "../scripts/perturbed_solve.py"


# E6 families: each date's extremal continued in the epoch to its neighbours, compared with the
# scan's extremal there (spaceopt.studies.scan_families; perturbed.e6.links, null: off)
E6_LINKS = link_settings(PT) if "e6" in PT["run"] else None
E6_LINK_PAIRS = link_pairs(PT) if E6_LINKS else []
E6_FAMILIES = [f"{PTDIR}/e6_families.csv"] if E6_LINKS else []     # the table, where links are on


def pt_e6_link_files():
    return [f"{PTDIR}/e6_links/{a}_to_{b}.json" for a, b in E6_LINK_PAIRS]


rule perturbed_e6_link:
    input: start=f"{PTDIR}/e6/{{a}}.json", scan=f"{PTDIR}/e6/{{b}}.json", src=PT_SRC,
           _src=lib_sources("studies/scan_families"), eph=pt_ephemeris(E6["case"], E6["model"])
    output: f"{PTDIR}/e6_links/{{a}}_to_{{b}}.json"
    wildcard_constraints: a=r"\d{4}-\d{2}-\d{2}", b=r"\d{4}-\d{2}-\d{2}"
    params: cfg=lambda w: {**pt_config_for(E6["case"], E6["model"]), "links": E6_LINKS},
            case=E6["case"], model=E6["model"], epoch=lambda w: f"{w.b}T{E6.get('time_utc', '12:00:00')}",
            results=RESULTS
    log: f"{PTDIR}/logs/e6_link_{{a}}_to_{{b}}.log"
    benchmark: f"{PTDIR}/benchmarks/e6_link_{{a}}_to_{{b}}.tsv"
    resources: mem_mb=4000, runtime=60
    script: "../scripts/perturbed_e6_link.py"


rule perturbed_e6_families:
    input: links=pt_e6_link_files(), dates=[f"{PTDIR}/e6/{d}.json" for d in E6_DATES],
           _src=lib_sources("studies/scan_families")
    output: f"{PTDIR}/e6_families.csv"
    params: dates=E6_DATES, starts=start_pairs(PT)
    log: f"{PTDIR}/logs/e6_families.log"
    script: "../scripts/perturbed_e6_families.py"


# E6 walks: a link's other extremal followed on, date by date, past its date; the envelope of
# every extremal found (spaceopt.studies.scan_walks; perturbed.e6.walks, null: off)
E6_WALKS = walk_settings(PT) if E6_LINKS else None
E6_ENVELOPE = [f"{PTDIR}/e6_envelope.csv"] if E6_WALKS else []
E6_WALKS_CSV = [f"{PTDIR}/e6_walks.csv"] if E6_WALKS else []


def pt_e6_walk_dates(w):
    """The link's date b, then the dates the walk may reach."""
    return [w.b] + walk_dates(PT, w.a, w.b)


def pt_e6_walk_files():
    return [f"{PTDIR}/e6_walks/{a}_to_{b}.json" for a, b in E6_LINK_PAIRS] if E6_WALKS else []


rule perturbed_e6_walk:
    input: link=f"{PTDIR}/e6_links/{{a}}_to_{{b}}.json",
           scan=lambda w: [f"{PTDIR}/e6/{d}.json" for d in pt_e6_walk_dates(w)], src=PT_SRC,
           _src=lib_sources("studies/scan_families", "studies/scan_walks"), eph=pt_ephemeris(E6["case"], E6["model"])
    output: f"{PTDIR}/e6_walks/{{a}}_to_{{b}}.json"
    wildcard_constraints: a=r"\d{4}-\d{2}-\d{2}", b=r"\d{4}-\d{2}-\d{2}"
    params: cfg=lambda w: {**pt_config_for(E6["case"], E6["model"]), "links": E6_LINKS, "walks": E6_WALKS},
            case=E6["case"], dates=pt_e6_walk_dates
    log: f"{PTDIR}/logs/e6_walk_{{a}}_to_{{b}}.log"
    benchmark: f"{PTDIR}/benchmarks/e6_walk_{{a}}_to_{{b}}.tsv"
    resources: mem_mb=4000, runtime=360
    script: "../scripts/perturbed_e6_walk.py"


rule perturbed_e6_envelope:
    input: walks=pt_e6_walk_files(), families=E6_FAMILIES, dates=[f"{PTDIR}/e6/{d}.json" for d in E6_DATES],
           _src=lib_sources("studies/scan_walks")
    output: steps=f"{PTDIR}/e6_walks.csv", envelope=f"{PTDIR}/e6_envelope.csv"
    params: dates=E6_DATES, links=E6_LINKS, time_utc=E6.get("time_utc", "12:00:00")
    log: f"{PTDIR}/logs/e6_envelope.log"
    script: "../scripts/perturbed_e6_envelope.py"


# The extremals of other families heavier than the scan's: saved as artifacts, re-propagated
# (spaceopt.studies.verify) and split by force (spaceopt.studies.force_shares)
E6_HEAVIER = [f"{PTDIR}/e6_envelope_extremals.csv"] if E6_WALKS else []


rule perturbed_e6_envelope_extremals:
    input: envelope=E6_ENVELOPE, links=pt_e6_link_files(), walks=pt_e6_walk_files(),
           dates=[f"{PTDIR}/e6/{d}.json" for d in E6_DATES], src=PT_SRC, eph=pt_ephemeris(E6["case"], E6["model"]),
           _src=lib_sources("studies/scan_walks", "studies/force_shares", "studies/verify")
    output: table=f"{PTDIR}/e6_envelope_extremals.csv", artifacts=directory(f"{PTDIR}/e6_envelope")
    params: cfg=lambda w: pt_config_for(E6["case"], E6["model"]), dates=E6_DATES,
            mass_tol_kg=(E6_LINKS or {}).get("mass_tol_kg"), samples_per_rev=E6.get("verify_samples_per_rev")
    log: f"{PTDIR}/logs/e6_envelope_extremals.log"
    benchmark: f"{PTDIR}/benchmarks/e6_envelope_extremals.tsv"
    resources: mem_mb=4000, runtime=60
    script: "../scripts/perturbed_e6_envelope_extremals.py"


# ---------------------------------------------------------------- E8 revolution counts

E8 = PT["e8"]


def pt_e8_inputs(w):
    src = pt_e8_source(w.n, w.model)
    out = {"src": PT_SRC, "eph": pt_ephemeris("e8", w.model)}
    if src is not None:
        out["start"] = f"{PTDIR}/e8/{src}.json"
    return out


rule perturbed_e8:
    input: unpack(pt_e8_inputs)
    output: pt_files("e8/{model}_n{n}")
    wildcard_constraints: n=r"[0-9.]+"
    params: cfg=lambda w: pt_config_for("e8", w.model), case="e8", model="{model}",
            n_rev=lambda w: float(w.n), source=lambda w: pt_e8_source(w.n, w.model) or "chain", results=RESULTS
    log: f"{PTDIR}/logs/e8_{{model}}_n{{n}}.log"
    benchmark: f"{PTDIR}/benchmarks/e8_{{model}}_n{{n}}.tsv"
    resources: mem_mb=4000, runtime=600
    threads: PT_THREADS
    script: "../scripts/perturbed_solve.py"


# ---------------------------------------------------------------- E9 ΔΩ budget

rule perturbed_e9_budget:
    input: src=lib_sources("studies/perturbed", "studies/perturbed_config", "studies/multirev_config", "forces", "elements", "frames")
    output: f"{PTDIR}/e9_budget.json"
    params: cfg=lambda w: pt_config_for("e9", PT["cases"]["e9"]["models"][0]),
            days=PT.get("e9_budget", {}).get("days", 5.0), model=PT["cases"]["e9"]["models"][0]
    log: f"{PTDIR}/logs/e9_budget.log"
    benchmark: f"{PTDIR}/benchmarks/e9_budget.tsv"
    script: "../scripts/perturbed_budget.py"


# ---------------------------------------------------------------- tables, figures, paper

def pt_stage_jsons():
    """{key: json} of every solve the run list asks for."""
    out = {}
    run = PT["run"]
    for case in ("e5", "e7", "e9"):
        if case in run:
            for m in PT["cases"][case]["models"]:
                out[f"{case}_{m}"] = f"{PTDIR}/{case}/{m}.json"
    if "e6" in run:      # with the scan's unperturbed line (the E5 unperturbed solve), also when E5 is not run
        for m in ("unperturbed", E6["model"]):
            out[f"e5_{m}"] = f"{PTDIR}/{E6['case']}/{m}.json"
        for d in E6_DATES:
            out[f"e6_{d}"] = f"{PTDIR}/e6/{d}.json"
    if "e8" in run:
        for m, n in e8_runs(PT):
            out[f"e8_{m}_n{_pt_fmt(n)}"] = f"{PTDIR}/e8/{m}_n{_pt_fmt(n)}.json"
    return out


def pt_verify_samples(w):
    """The E6 dates, the minimum-thrust solves and the thrust families' points are re-sampled from
    their unknowns for the check (perturbed.e6.verify_samples_per_rev,
    perturbed.existence.verify_samples_per_rev)."""
    if w.solve.startswith("e6/"):
        return E6.get("verify_samples_per_rev")
    if "/tmin_" in w.solve or "/family_" in w.solve:      # (the families' least-thrust points: engines all but always on)
        return (PT.get("existence") or {}).get("verify_samples_per_rev")
    return None


rule perturbed_verify:
    input: json=f"{PTDIR}/{{solve}}.json", src=lib_sources("studies/verify", "forces", "ephemeris", "frames"),
           solver=lambda w: PT_SRC if pt_verify_samples(w) else []
    output: f"{PTDIR}/{{solve}}.verify.json"
    wildcard_constraints: solve=r"(e5|e6|e7|e8|e9)/[^/]+"
    params: samples_per_rev=pt_verify_samples
    log: f"{PTDIR}/logs/verify_{{solve}}.log"
    benchmark: f"{PTDIR}/benchmarks/verify_{{solve}}.tsv"
    resources: mem_mb=2000, runtime=30
    script: "../scripts/verify_ot.py"


def pt_verify_files():
    """The independent Cartesian re-propagation of every solve the tables take, and of the
    minimum-thrust solves of the existence check."""
    return sorted({p.replace(".json", ".verify.json") for p in [*pt_stage_jsons().values(), *pt_existence_files(),
                                                                 *TF_FILES]})


# What each force contributes to the change of h and E along every perturbed solve of the listed
# cases (spaceopt.studies.force_shares; perturbed.force_shares, null: off)
FS_CASES = [c for c in (PT.get("force_shares") or {}).get("cases", []) if c in PT["run"]]


def pt_force_share_files():
    """The force shares of every solve of FS_CASES that has perturbations (the models the tables take)."""
    perturbed = lambda m: bool(PT["models"][m])  # noqa: E731
    out = []
    for case in FS_CASES:
        if case == "e6":
            out += [f"{PTDIR}/e6/{d}.shares.json" for d in E6_DATES if perturbed(E6["model"])]
        elif case == "e8":
            out += [f"{PTDIR}/e8/{m}_n{_pt_fmt(n)}.shares.json" for m, n in e8_runs(PT) if perturbed(m)]
        else:
            out += [f"{PTDIR}/{case}/{m}.shares.json" for m in PT["cases"][case]["models"] if perturbed(m)]
    return out


FS_TABLE = [f"{PTDIR}/force_shares.csv"] if pt_force_share_files() else []
FS_BY_REVOLUTION = [f"{PTDIR}/force_shares_by_revolution.csv"] if FS_TABLE else []


rule perturbed_force_shares:
    input: json=f"{PTDIR}/{{solve}}.json",
           src=lib_sources("studies/force_shares", "studies/verify", "forces", "ephemeris", "frames")
    output: f"{PTDIR}/{{solve}}.shares.json"
    wildcard_constraints: solve=r"(e5|e6|e7|e8|e9)/[^/]+"
    log: f"{PTDIR}/logs/shares_{{solve}}.log"
    benchmark: f"{PTDIR}/benchmarks/shares_{{solve}}.tsv"
    resources: mem_mb=2000, runtime=30
    script: "../scripts/force_shares.py"


rule perturbed_force_shares_table:
    input: shares=pt_force_share_files(), _src=lib_sources("studies/force_shares")
    output: table=f"{PTDIR}/force_shares.csv", by_revolution=f"{PTDIR}/force_shares_by_revolution.csv"
    log: f"{PTDIR}/logs/force_shares.log"
    script: "../scripts/force_shares_table.py"


# Does the transfer exist with the perturbations on? The minimum-thrust problem of each listed case
# under the unperturbed model and each of the case's models, from the zero guess
# (spaceopt.studies.existence; perturbed.existence, null: off)
EX_RUNS = existence_runs(PT)
EX_BOUND_FROM = existence_bound_from(PT)
if REPORT_FAILED:        # the report pass: minimum-thrust solves that failed are left out (failed_solves),
    # and those that carry a failed one's bound over (existence.bound_from)
    PT_FAILED["existence"] = left_out(EX_RUNS, lambda r: (r[0], EX_BOUND_FROM[r]) if r in EX_BOUND_FROM else None,
                                      lambda r: diagnosis(f"{PTDIR}/{r[0]}/tmin_{r[1]}.json"),
                                      lambda r: f"{r[0]}/tmin_{r[1]}")


def pt_existence_files():
    """The minimum-thrust artifacts: per listed case, unperturbed first, then the case's models
    (less those left out by the report pass)."""
    return [f"{PTDIR}/{c}/tmin_{m}.json" for c, m in EX_RUNS if (c, m) not in PT_FAILED["existence"]]


EX_TABLE = [f"{PTDIR}/existence.csv"] if pt_existence_files() else []


EX_FROM_OT = existence_from_ot(PT)


def pt_existence_cfg(w):
    """A from_ot case's check also depends on its options (``existence.from_ot``), and a model
    that carries another's bound over on that model (``existence.bound_from``)."""
    cfg = pt_config_for(w.case, w.model)
    if w.case not in EX_FROM_OT:
        return cfg
    cfg = {**cfg, "existence_from_ot": EX_FROM_OT[w.case]}
    source = EX_BOUND_FROM.get((w.case, w.model))
    return {**cfg, "existence_bound_from": source} if source else cfg


def pt_existence_start(w):
    """The OT artifact a from_ot check starts from, or the other model's bound it carries over."""
    if w.case not in EX_FROM_OT:
        return []
    source = EX_BOUND_FROM.get((w.case, w.model))
    return [f"{PTDIR}/{w.case}/tmin_{source}.json" if source else f"{PTDIR}/{w.case}/{w.model}.json"]


rule perturbed_existence:
    input: src=PT_SRC + lib_sources("studies/existence"), eph=lambda w: pt_ephemeris(w.case, w.model),
           ot=pt_existence_start
    output: pt_files("{case}/tmin_{model}")
    wildcard_constraints: case="e5|e7|e9", model="|".join(sorted(PT["models"]))
    params: cfg=pt_existence_cfg, case="{case}", model="{model}", results=RESULTS
    log: f"{PTDIR}/logs/{{case}}_tmin_{{model}}.log"
    benchmark: f"{PTDIR}/benchmarks/{{case}}_tmin_{{model}}.tsv"
    resources: mem_mb=4000, runtime=60
    script: "../scripts/perturbed_existence.py"


rule perturbed_existence_table:
    input: tmin=pt_existence_files(), _src=lib_sources("studies/existence")
    output: f"{PTDIR}/existence.csv"
    log: f"{PTDIR}/logs/existence.log"
    script: "../scripts/perturbed_existence_table.py"


# The minimum-fuel family followed down in the thrust from the case's OT solution, per listed model:
# what a weaker engine costs, and an upper bound on T_min below the existence check's; and, per
# carry_from entry, a model's family started from another model's least-thrust point carried to it
# (spaceopt.studies.thrust_family; perturbed.thrust_family, absent: off)
TF = thrust_family_settings(PT)
TF_RUNS = [(c, m, "") for c, s in TF.items() for m in s["models"]] + [
    (c, m, seed) for c, s in TF.items() for m, seed in s["carry_from"].items()]


def tf_file(case, model, seed=""):
    return f"{PTDIR}/{case}/family_{model}" + (f"_from_{seed}" if seed else "") + ".json"


if REPORT_FAILED:        # the report pass: a carried family whose carry failed is left out (failed_solves)
    PT_FAILED["family"] = left_out([r for r in TF_RUNS if r[2]], lambda r: None, lambda r: diagnosis(tf_file(*r)),
                                   lambda r: tf_file(*r))
TF_FILES = [tf_file(*r) for r in TF_RUNS if r not in PT_FAILED["family"]]
TF_TABLE = [f"{PTDIR}/thrust_family.csv"] if TF_RUNS else []
TF_FIGURES = [f"fig_{c}_thrust_family" for c in TF]
TF_SRC = lib_sources("studies/thrust_family")


rule perturbed_thrust_family:
    input: src=PT_SRC + TF_SRC, eph=lambda w: pt_ephemeris(w.case, w.model),
           ot=f"{PTDIR}/{{case}}/{{model}}.json"
    output: pt_files("{case}/family_{model}")
    wildcard_constraints: case="|".join(TF) or "none", model="|".join(sorted(PT["models"]))
    params: cfg=lambda w: {**pt_config_for(w.case, w.model), "thrust_family": TF[w.case]},
            case="{case}", model="{model}", seed="", results=RESULTS
    log: f"{PTDIR}/logs/{{case}}_family_{{model}}.log"
    benchmark: f"{PTDIR}/benchmarks/{{case}}_family_{{model}}.tsv"
    resources: mem_mb=4000, runtime=240
    script: "../scripts/perturbed_thrust_family.py"


use rule perturbed_thrust_family as perturbed_thrust_family_carried with:
    input: src=PT_SRC + TF_SRC, eph=lambda w: pt_ephemeris(w.case, w.model),
           seed=f"{PTDIR}/{{case}}/family_{{seed}}.json"
    output: pt_files("{case}/family_{model}_from_{seed}")
    wildcard_constraints: case="|".join(TF) or "none", model="|".join(sorted(PT["models"])),
                          seed="|".join(sorted(PT["models"]))
    params: cfg=lambda w: {**pt_config_for(w.case, w.model), "thrust_family": TF[w.case]},
            case="{case}", model="{model}", seed="{seed}", results=RESULTS
    log: f"{PTDIR}/logs/{{case}}_family_{{model}}_from_{{seed}}.log"
    benchmark: f"{PTDIR}/benchmarks/{{case}}_family_{{model}}_from_{{seed}}.tsv"


rule perturbed_thrust_family_table:
    input: family=TF_FILES, _src=lib_sources("studies/thrust_family", "studies/perturbed_figures", "report/figures")
    output: table=f"{PTDIR}/thrust_family.csv",
            figures=[f"{PTDIR}/figures/{f}.{ext}" for f in TF_FIGURES for ext in ("pdf", "png")]
    log: f"{PTDIR}/logs/thrust_family.log"
    script: "../scripts/perturbed_thrust_family_table.py"


PT_TABLES = ["e5", "e6_date_scan", "e7", "e8", "e9"]

rule perturbed_tables:
    input: **pt_stage_jsons(), _budget=f"{PTDIR}/e9_budget.json",
           _pub="config/published/yun2023_perturbed.yaml", _verify=pt_verify_files(), _envelope=E6_ENVELOPE,
           _src=lib_sources("report/compare", "report/verification", "studies/perturbed_report")
    output:
        **{t: f"{PTDIR}/{t}.csv" for t in PT_TABLES},
        repro=f"{PTDIR}/reproduction.csv",
        verify=f"{PTDIR}/verification.csv",
        tof_maximum=f"{PTDIR}/tof_maximum.csv",
        md=f"{PTDIR}/tables.md",
        tex=f"{PTDIR}/tables/perturbed.tex",
    params: run=PT["run"], cases={c: {"models": PT["cases"][c]["models"]} for c in PT["cases"]},
            e6=E6, e8_n=E8["run_n_rev"]
    log: f"{PTDIR}/logs/tables.log"
    benchmark: f"{PTDIR}/benchmarks/tables.tsv"
    script: "../scripts/perturbed_tables.py"


PT_FIGS = {"e5": ["fig_4_2_1_1", "fig_4_2_1_2", "fig_4_2_1_3"], "e6": ["fig_4_2_1_4", "fig_4_2_1_5"],
           "e7": ["fig_4_2_1_6"], "e8": ["fig_4_2_2_1", "fig_4_2_2_3", "fig_4_2_2_5"],
           "e9": ["fig_4_2_3_1", "fig_4_2_3_2"]}


def pt_figure_names():
    """The figures of the cases in the run list; E9 draws one figure per model, for its first two."""
    n_e9 = min(2, len(PT["cases"]["e9"]["models"]))
    return [f for c in PT["run"] for f in (PT_FIGS[c][:n_e9] if c == "e9" else PT_FIGS[c])] + (
        ["fig_e6_force_shares"] if "e6" in FS_CASES and FS_TABLE else [])


rule perturbed_figures:
    input: **pt_stage_jsons(), _src=lib_sources("studies/perturbed_figures", "studies/scan_families", "report/figures"),
           _families=E6_FAMILIES, _walks=E6_WALKS_CSV, _envelope=E6_ENVELOPE, _force_shares=FS_TABLE,
           _envelope_extremals=E6_HEAVIER
    output: [f"{PTDIR}/figures/{f}.{ext}" for f in pt_figure_names() for ext in ("pdf", "png")]
    params: run=PT["run"], cases={c: {"models": PT["cases"][c]["models"]} for c in PT["cases"]},
            e6=E6, e8_n=E8["run_n_rev"], style=PT.get("figures", {})
    log: f"{PTDIR}/logs/figures.log"
    benchmark: f"{PTDIR}/benchmarks/figures.tsv"
    script: "../scripts/perturbed_figures.py"


rule perturbed_paper_section:
    input: repro=f"{PTDIR}/reproduction.csv", tables=f"{PTDIR}/tables/perturbed.tex",
           verify=f"{PTDIR}/verification.csv", tof_maximum=f"{PTDIR}/tof_maximum.csv",
           budget=f"{PTDIR}/e9_budget.json",
           figures=[f"{PTDIR}/figures/{f}.pdf" for f in pt_figure_names()],
           families=E6_FAMILIES, walks=E6_WALKS_CSV, envelope=E6_ENVELOPE, heavier=E6_HEAVIER, force_shares=FS_TABLE,
           force_shares_by_revolution=FS_BY_REVOLUTION, existence=EX_TABLE, **{t: f"{PTDIR}/{t}.csv" for t in PT_TABLES},
           thrust_family=TF_TABLE, thrust_family_runs=TF_FILES,
           family_figures=[f"{PTDIR}/figures/{f}.pdf" for f in TF_FIGURES],
           _src=lib_sources("studies/perturbed_report", "report/verification", "studies/scan_families",
                            "studies/scan_walks", "studies/force_shares", "studies/existence", "studies/thrust_family")
    output: f"{PTDIR}/paper_section.tex"
    params: run=PT["run"], results=RESULTS, e8_count_start=e8_count_start(PT), e8_smoothing=e8_smoothing(PT),
            e6_skipped=config["perturbed"]["e6"].get("skip_dates") or [],
            e8_skipped=e8_skipped(config["perturbed"]) if "e8" in PT["run"] else [],
            failures=failures_sentence(**PT_FAILED),
            e8_steps=e8_model_steps(PT), e6_dates=E6_DATES, e6_links=E6_LINKS
    log: f"{PTDIR}/logs/paper_section.log"
    script: "../scripts/perturbed_paper_section.py"


ALL_TARGETS += [f"{PTDIR}/{t}.csv" for t in PT_TABLES] + [
    f"{PTDIR}/reproduction.csv", f"{PTDIR}/paper_section.tex", f"{PTDIR}/e9_budget.json"] + [
    f"{PTDIR}/figures/{f}.pdf" for f in pt_figure_names()] + E6_FAMILIES + E6_ENVELOPE + E6_HEAVIER + FS_TABLE + FS_BY_REVOLUTION + EX_TABLE + TF_TABLE
