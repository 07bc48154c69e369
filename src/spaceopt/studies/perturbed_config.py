"""The ``perturbed`` section of the config (dissertation §4.2, E5–E9): the runs the DAG plans
from it, and the case options that plan and the solves' paths read (start model, model step,
path tolerances and arcs, switching, corrector, the ε of a switch-on).

Each reader names the offending key and value in a one-line ConfigError. The module imports no
solver (diffrax, optimistix, the chain): the Snakefile plans the perturbed DAG with it (which
dates, counts, models and existence checks run, and what each starts from), and every Snakemake
run pays for what it imports. The options only a solve reads (the case keys of a transfer,
``warm_step_growth``, ``tof_maximum``) stay with the solves in :mod:`spaceopt.studies.perturbed`.
"""
from __future__ import annotations

from ..errors import ConfigError
from ..indirect.continuation import ACCEPTED_UPDATES, CORRECTORS, GROWTH
from ..indirect.transfer import PATH_RTOL, SWITCHINGS
from .multirev_config import number, positive_integer


# ---------------------------------------------------------------- case options

MODEL_STEP_PATHS = ("tau", "arclength")
STEP_SETTINGS = ("step_growth", "accepted_update", "corrector", "step_rcond", "flat_step", "end_overshoot", "h_max")


def _per_model(cc: dict, key: str, model: str, path: str, default, read):
    """Case option ``key``: one value for every model of the case, or a mapping {model: value}
    (models not named or null, and cases without the option, get ``default``: a profile removes a
    model's value by writing null over it); ``read(cfg, key, path)`` checks a value."""
    val = cc.get(key)
    if not isinstance(val, dict):
        return default if val is None else read(cc, key, path)
    unknown = sorted(set(val) - set(cc["models"]))
    if unknown:
        raise ConfigError(f"{path}.{key}.{unknown[0]}", val[unknown[0]],
                          f"not a model of the case (expected one of {', '.join(cc['models'])})")
    return default if val.get(model) is None else read(val, model, f"{path}.{key}")


def case_path_rtol(cc: dict, model: str, path: str) -> float:
    """Case option ``path_rtol``: the integration rtol while a homotopy path is followed, one
    number for every model of the case, or a mapping {model: rtol} (models not named, and cases
    without the option, keep the default PATH_RTOL). E8 names its 4×4 and full models: at 1e-9 the
    propagated Jacobian of 4×4 + Moon + Sun is too inaccurate for Newton's corrector (‖J⁻¹ δJ‖ =
    2.5 at the converged 200-revolution extremal; 0.27 at 1e-10, 0.008 at 1e-11, measured by
    docs/experiments/path_jacobian_accuracy.py). Its unperturbed chain follows its paths at a looser
    1e-7 (docs/perturbed-guide.md §4)."""
    return _per_model(cc, "path_rtol", model, path, PATH_RTOL,
                      lambda cfg, key, where: number(cfg, key, where, positive=True))


def case_sensitivity_rtol(pc: dict, case: str, model: str) -> float | None:
    """Case option ``sensitivity_rtol`` (a number or {model: number}, like ``path_rtol``): the
    integration rtol of the exact map's sensitivities where it is looser than the residual's
    (``Shooting.sensitivity_rtol``; None, the default: the residual's). Newton and the path
    correctors need ‖J⁻¹ δJ‖ ≪ 1, not the residual's accuracy: on the exact map at E8 500 rev,
    1e-9 against 1e-11 gives ‖J⁻¹ δJ‖ 1.8e-2 at the full model's extremal and 0.23 at τ 0.5 of
    the 4×4 → full blend, whose Jacobian is 1.41× cheaper (docs/perturbed-e6-e7-e8.md,
    "forty-first session"). Only with ``switching: exact``: the
    smoothed map integrates f and Φ in one solve, and at ε_f its Jacobian needs the tight path
    tolerance (:func:`case_path_rtol`)."""
    cc, path = pc["cases"][case], f"perturbed.cases.{case}"
    if cc.get("sensitivity_rtol") is not None and case_switching(pc, case) != "exact":
        raise ConfigError(f"{path}.sensitivity_rtol", cc["sensitivity_rtol"],
                          "a separate Jacobian tolerance needs the exact bang-bang map (switching: exact)")
    return _per_model(cc, "sensitivity_rtol", model, path, None,
                      lambda cfg, key, where: number(cfg, key, where, positive=True))


def case_path_arcs(cc: dict, model: str, path: str) -> int:
    """Case option ``path_arcs`` (a number or {model: number}, like ``path_rtol``): the number
    of shooting arcs while a homotopy path into that model is followed (1, single shooting, by
    default; :mod:`spaceopt.indirect.multiple_shooting`)."""
    def read(cfg, key, where):
        val = cfg[key]
        if isinstance(val, bool) or not isinstance(val, int) or val < 1:
            raise ConfigError(f"{where}.{key}", val, "must be a whole number of shooting arcs >= 1")
        return val
    return _per_model(cc, "path_arcs", model, path, 1, read)


def case_path_step_budget(cc: dict, path: str) -> float | None:
    """Case option ``path_step_budget`` (a factor >= 1; absent or null: off): each path's
    propagations capped at that multiple of the steps of the path's last successful Jacobian
    evaluation (:class:`spaceopt.indirect.chain.PathStepBudget`)."""
    if cc.get("path_step_budget") is None:
        return None
    value = number(cc, "path_step_budget", path)
    if value < 1:
        raise ConfigError(f"{path}.path_step_budget", value,
                          "expected a factor >= 1 on the steps of the path's last successful evaluation")
    return value


def perturb_at_eps(pc: dict, case: str, key: str = "perturb_at_eps") -> float | None:
    """Case option ``perturb_at_eps`` (or ``model_step_at_eps``): the smoothing ε at which the
    perturbations are switched on (:func:`.perturbed.perturb_from_unperturbed`), or a perturbed
    force model is changed (:func:`.perturbed.warm_start`), between ε_f and 1; None (absent) does
    it at ε_f."""
    eps = pc["cases"][case].get(key)
    if eps is None:
        return None
    val = number(pc["cases"][case], key, f"perturbed.cases.{case}", positive=True)
    if not pc["numerics"]["eps_final"] < val <= 1.0:
        raise ConfigError(f"perturbed.cases.{case}.{key}", eps, "must lie in (eps_final, 1]")
    return val


def case_switching(pc: dict, case: str) -> str:
    """Case option ``switching``: 'smoothed' (the default), the smoothed throttle (3.3.2) down to
    ε_f, or 'exact', the exact bang-bang map (:mod:`spaceopt.indirect.exact_switching`): the chain
    stops its ε descent at ε₁ and Newton takes it to ε = 0, and every later solve of the case stays
    on the exact map (its warm starts read the switching from their start). The options of the
    smoothed route that need a smoothing ε or multiple shooting are refused with it."""
    cc, path = pc["cases"][case], f"perturbed.cases.{case}"
    value = cc.get("switching", "smoothed")
    if value not in SWITCHINGS:
        raise ConfigError(f"{path}.switching", value, f"expected one of {', '.join(SWITCHINGS)}")
    if value == "exact":
        for key in ("perturb_at_eps", "model_step_at_eps"):
            if cc.get(key) is not None:
                raise ConfigError(f"{path}.{key}", cc[key],
                                  "the exact bang-bang map (switching: exact) has no smoothing eps")
        arcs = cc.get("path_arcs")
        if arcs is not None and any(v > 1 for v in (arcs.values() if isinstance(arcs, dict) else [arcs])):
            raise ConfigError(f"{path}.path_arcs", arcs, "the exact bang-bang map (switching: exact) is single shooting")
        if case == "e8" and "e8" in pc and e8_count_start(pc) != "chain":     # (a job's config has no e8 part)
            raise ConfigError("perturbed.e8.count_start", e8_count_start(pc),
                              "a count moved from the previous one needs the smoothing eps (switching: exact)")
    return value


def case_corrector(pc: dict, case: str) -> str:
    """Case option ``corrector``: 'newton' (the default), a Jacobian at every corrector
    evaluation, 'chord', the corrector's later steps with the Jacobian of its first and f
    alone, or 'broyden', the Jacobian carried across steps by rank-one updates
    (:mod:`spaceopt.indirect.continuation`), on the paths of the chain from the zero guess
    (:func:`.perturbed.chain_options`). The warm starts keep Newton's: their steps converge in one
    or two corrector evaluations, so the chord saves little, and on the exact map at E8 500 rev the 4×4
    blend with it stalled at τ 0.6 (the accepted point's update, with the predictor's Jacobian,
    crossed an edge of the map), and took 152 s with ``accepted_update`` revert against Newton's
    103 s (docs/perturbed-e6-e7-e8.md, "thirty-seventh session")."""
    value = pc["cases"][case].get("corrector", "newton")
    if value not in CORRECTORS:
        raise ConfigError(f"perturbed.cases.{case}.corrector", value, f"expected one of {', '.join(CORRECTORS)}")
    return value


def _at_n_rev(cfg: dict, where: str, what: str) -> list[tuple[float, object, str]]:
    """The entries of ``cfg``'s ``at_n_rev`` mapping ({revolution count: ``what``}), checked:
    (count, value, its config key)."""
    counts = cfg.get("at_n_rev", {})
    if not isinstance(counts, dict):
        raise ConfigError(f"{where}.at_n_rev", counts, f"expected a mapping {{revolution count: {what}}}")
    for count, value in counts.items():
        if isinstance(count, bool) or not isinstance(count, (int, float)) or count <= 0:
            raise ConfigError(f"{where}.at_n_rev.{count}", value, "the key must be a positive revolution count")
    return [(float(count), value, f"{where}.at_n_rev.{count}") for count, value in counts.items()]


def case_model_step(cc: dict, model: str, path: str, n_rev: float | None = None) -> dict:
    """Case option ``model_step`` ({model: settings}): how the warm start into that model is
    followed, ``path`` ('tau', the default: τ, then its fallbacks; 'arclength': the model blend
    in arclength at once; for the perturbations switched on from an unperturbed solution the
    default is arclength) and the continuation options ``step_growth``, ``accepted_update``,
    ``corrector``, ``step_rcond``, ``flat_step``, ``end_overshoot`` and ``h_max`` (the largest
    step, in the path's own measure; :class:`~spaceopt.indirect.continuation.ContinuationOptions`,
    :class:`~spaceopt.indirect.continuation.ArclengthOptions`).
    E8 (on the exact map) switches J2 on in τ with the chord corrector: at 500 revolutions 14
    Jacobians against 37 with Newton's in τ and 52 in arclength, the same extremal
    (docs/perturbed-e6-e7-e8.md, "forty-second session").
    ``at_n_rev: {count: settings}`` overrides those continuation options for one revolution
    count ``n_rev`` (E8 450: the full model's arclength path with h_max 0.1, whose end point
    has the flat-direction root 0.008 away where h_max 0.3 leaves it 0.02 away, beyond the
    chords' reach; docs/perturbed-e6-e7-e8.md, "twelfth" and "thirteenth session"). E8 names
    its full model (the 4×4 → 4×4 + Moon + Sun step at 450-500 revolutions, "ninth session").
    Models not named get {}."""
    def check(settings, where, allowed):
        if not isinstance(settings, dict):
            raise ConfigError(where, settings, "expected a mapping of model-step settings")
        choices = {"path": MODEL_STEP_PATHS, "step_growth": GROWTH, "accepted_update": ACCEPTED_UPDATES,
                   "corrector": CORRECTORS}
        for k, v in settings.items():
            if k not in allowed:
                raise ConfigError(f"{where}.{k}", v, f"unknown setting (expected {', '.join(allowed)})")
            if k in choices:
                if v not in choices[k]:
                    raise ConfigError(f"{where}.{k}", v, f"expected one of {', '.join(choices[k])}")
            elif k == "h_max":
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v <= 1:
                    raise ConfigError(f"{where}.{k}", v, "expected a number in (0, 1]")
            elif k != "at_n_rev" and (isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 <= v < 1):
                raise ConfigError(f"{where}.{k}", v, "expected a number in [0, 1)")

    def read(cfg, key, where):
        val = cfg[key]
        where = f"{where}.{key}"
        check(val, where, ("path", *STEP_SETTINGS, "at_n_rev"))
        chosen = {}
        for count, settings, key in _at_n_rev(val, where, "settings"):
            check(settings, key, STEP_SETTINGS)
            if n_rev is not None and count == float(n_rev):
                chosen = settings
        return {**{k: v for k, v in val.items() if k != "at_n_rev"}, **chosen}
    return _per_model(cc, "model_step", model, path, {}, read)


def case_start_model(pc: dict, case: str, model: str, n_rev: float | None = None) -> str | None:
    """The model whose converged solution the solve of (``case``, ``model``) starts from, or None
    where that solve is the chain from the zero guess: the case's first model, and every model
    when the case says ``model_start: chain`` (E5, E7). Otherwise the model the case option
    ``model_from`` ({model: an earlier model of the case}) names for it, else the one before it in
    ``models``. E8 (on the exact map) starts the full model from J2: on the exact map at 500
    revolutions the J2 → full blend took 44 Jacobians and landed on the certified maximum, where
    J2 → 4×4 → full took 16 + 64 and an end game of 33 (docs/perturbed-e6-e7-e8.md,
    "forty-second session"); 4×4 is then a solve beside the route, not on it.
    A ``model_from`` entry may instead be a mapping ``{model: start, at_n_rev: {count: start}}``
    (``model`` optional, the previous model by default): the start at revolution count ``n_rev``
    where ``at_n_rev`` names it (E8 only, the case with counts). On the smoothed route the full
    model starts from J2 at 450 revolutions only: there the route through 4×4 reaches no maximum,
    from J2 it certifies one; at 300 the J2 start lands on a neighbouring maximum 0.08 g heavier in
    propellant (docs/perturbed-e6-e7-e8.md, "forty-fourth", "fifty-first" and "fifty-second
    session"). ``n_rev`` None: the start the entry names for every count."""
    cc, where = pc["cases"][case], f"perturbed.cases.{case}.model_from"
    models, model_from = cc["models"], cc.get("model_from") or {}
    chained = cc.get("model_start", "previous") == "chain"
    if model_from and chained:
        raise ConfigError(where, model_from, "every model starts from the zero guess here (model_start: chain)")
    starts = {target: _model_from_entry(models, case, target, entry, f"{where}.{target}")
              for target, entry in model_from.items()}
    if model == models[0] or chained:
        return None
    default, at_n_rev = starts.get(model, (models[models.index(model) - 1], {}))
    return at_n_rev.get(float(n_rev), default) if n_rev is not None else default


def _model_from_entry(models: list, case: str, target: str, entry, where: str) -> tuple[str, dict]:
    """One ``model_from`` entry, checked: (its start model for every count, {count: start})."""
    if target not in models[1:]:
        raise ConfigError(where, entry, f"not a model of the case after its first ({', '.join(models[1:])})")

    def start(value, key):
        if value not in models[:models.index(target)]:
            raise ConfigError(key, value, f"must name a model before {target} in the case's models")
        return value
    if not isinstance(entry, dict):
        return start(entry, where), {}
    for key, value in entry.items():
        if key not in ("model", "at_n_rev"):
            raise ConfigError(f"{where}.{key}", value, "unknown setting (expected model, at_n_rev)")
    if case != "e8" and entry.get("at_n_rev"):
        raise ConfigError(f"{where}.at_n_rev", entry["at_n_rev"], "only E8 has revolution counts")
    at_n_rev = {count: start(value, key) for count, value, key in _at_n_rev(entry, where, "start model")}
    return start(entry.get("model", models[models.index(target) - 1]), f"{where}.model"), at_n_rev


def case_route(pc: dict, case: str, model: str, n_rev: float | None = None) -> list[str]:
    """The models whose solves lead to (``case``, ``model``) at revolution count ``n_rev``, in
    order, ``model`` last: its start model's route (:func:`case_start_model`), from the solve that
    starts from the zero guess."""
    start = case_start_model(pc, case, model, n_rev)
    return [model] if start is None else case_route(pc, case, start, n_rev) + [model]


def case_start_models(pc: dict) -> dict:
    """{case: {model: start model or None}} of every case (checks each case's ``model_from``)."""
    return {case: {m: case_start_model(pc, case, m) for m in cc["models"]} for case, cc in pc["cases"].items()}


# ---------------------------------------------------------------- E6 dates, links and walks

def scan_dates(e6: dict) -> list[str]:
    """UTC epochs of the departure scan (``perturbed.e6``)."""
    from datetime import date, timedelta
    try:
        d0 = date.fromisoformat(e6["first_date"])
        d1 = date.fromisoformat(e6["last_date"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ConfigError("perturbed.e6.first_date/last_date", e6.get("first_date"), f"bad date ({exc})") from None
    step = positive_integer(e6.get("step_days", 1), "perturbed.e6.step_days")
    if d1 < d0:
        raise ConfigError("perturbed.e6.last_date", e6["last_date"], "before first_date")
    out, d = [], d0
    while d <= d1:
        out.append(f"{d.isoformat()}T{e6.get('time_utc', '12:00:00')}")
        d += timedelta(days=step)
    return out


def scan_order(dates: list[str], anchor: str) -> list[tuple[str, str]]:
    """(date, warm-start source) pairs: outward from the anchor date, each from its neighbour."""
    if anchor not in dates:
        raise ConfigError("perturbed.e6", anchor, "the anchor epoch (the E5 date) must be one of the scan dates")
    i = dates.index(anchor)
    pairs = []
    for j in range(i + 1, len(dates)):
        pairs.append((dates[j], dates[j - 1]))
    for j in range(i - 1, -1, -1):
        pairs.append((dates[j], dates[j + 1]))
    return pairs


def scan_start_from(e6: dict) -> dict[str, str]:
    """``perturbed.e6.start_from``: dates (YYYY-MM-DD) that warm-start from a named, converged
    neighbouring date instead of the scan's ``warm_start`` route (E6: where the perturbation
    switch from the unperturbed solve turns back). Checked: both are scan dates, and following
    the map from any date ends at a date on the default route (no cycle)."""
    start_from = e6.get("start_from") or {}
    days = {d[:10] for d in scan_dates(e6)}
    for date, src in start_from.items():
        for value in (date, src):
            if value not in days:
                raise ConfigError(f"perturbed.e6.start_from.{date}", value, "not a date of the scan")
    for date in start_from:
        seen, d = {date}, start_from[date]
        while d in start_from:
            if d in seen:
                raise ConfigError(f"perturbed.e6.start_from.{date}", start_from[date], "the starts form a cycle")
            seen.add(d)
            d = start_from[d]
    return dict(start_from)


def scan_source(pc: dict, date: str) -> str | None:
    """What E6 date ``date`` (YYYY-MM-DD) warm-starts from: a date of ``start_from`` from the
    converged date named there; otherwise, with ``warm_start: unperturbed`` (the default),
    'unperturbed' (the date-independent unperturbed OT of the E6 case, perturbations then
    switched on by τ: every date an independent job); with ``warm_start: neighbour``, the
    neighbouring date towards the E5 anchor (None for the anchor: the E5 solve itself)."""
    e6 = pc["e6"]
    start_from = scan_start_from(e6)
    if date in start_from:
        return start_from[date]
    if e6.get("warm_start", "unperturbed") == "unperturbed":
        return "unperturbed"
    anchor = pc["cases"][e6["case"]]["epoch_utc"]
    return dict((d[:10], s[:10]) for d, s in scan_order(scan_dates(e6), anchor)).get(date)


def scan_run_dates(pc: dict) -> list[str]:
    """The E6 dates (YYYY-MM-DD) the DAG solves: the scan's dates less ``perturbed.e6.skip_dates``
    (dates whose solve does not converge on a machine, left out so that the tables, figures and
    paper are built without them; the report lists them). Checked: each skipped date is a scan
    date, and no date that is run starts from a skipped one."""
    e6 = pc["e6"]
    days = [d[:10] for d in scan_dates(e6)]
    skip = e6.get("skip_dates") or []
    for d in skip:
        if d not in days:
            raise ConfigError("perturbed.e6.skip_dates", d, "not a date of the scan")
    run = [d for d in days if d not in skip]
    for d in run:
        src = scan_source(pc, d)
        if src in skip:
            raise ConfigError("perturbed.e6.skip_dates", src,
                              f"date {d} starts from it (start_from / warm_start: neighbour); skip {d} too, or start it elsewhere")
    return run


def link_settings(pc: dict) -> dict | None:
    """``perturbed.e6.links`` (schema-checked), or None where it is absent or null (off)."""
    return pc["e6"].get("links") or None


def start_pairs(pc: dict) -> list[tuple[str, str]]:
    """(source, date) of every run date the scan starts from a neighbouring run date."""
    dates = scan_run_dates(pc)
    return [(scan_source(pc, d), d) for d in dates if scan_source(pc, d) in dates]


def link_pairs(pc: dict) -> list[tuple[str, str]]:
    """The ordered (from, to) pairs of neighbouring run dates that get a link job: forwards, and
    backwards with ``directions: both``, less the pairs whose solve is the link (:func:`start_pairs`).
    Neighbours are consecutive run dates (a date left out by ``skip_dates`` is stepped over)."""
    settings = link_settings(pc)
    if not settings:
        return []
    dates = scan_run_dates(pc)
    pairs = list(zip(dates, dates[1:]))
    if settings.get("directions", "both") == "both":
        pairs += [(b, a) for a, b in pairs]
    starts = set(start_pairs(pc))
    return [p for p in pairs if p not in starts]


def walk_settings(pc: dict) -> dict | None:
    """``perturbed.e6.walks`` (schema-checked), or None where it or the links are off."""
    e6 = pc["e6"]
    return (e6.get("walks") or None) if e6.get("links") else None


def walk_dates(pc: dict, a: str, b: str) -> list[str]:
    """The run dates past b, away from a, that the walk of link (a, b) may reach: at most
    ``max_days`` of them, nearest first."""
    dates = scan_run_dates(pc)
    i = dates.index(b)
    ahead = dates[i + 1:] if b > a else dates[:i][::-1]
    return ahead[:int(walk_settings(pc)["max_days"])]


# ---------------------------------------------------------------- E8 counts

def e8_count_start(pc: dict) -> str:
    """How each E8 count of the case's first model starts (``perturbed.e8.count_start``, enum
    checked by the schema): 'chain' (the default), from the zero guess, or 'previous', from the
    next smaller count."""
    return pc["e8"].get("count_start", "chain")


def e8_smoothing(pc: dict) -> dict:
    """The smoothing ε values the E8 route uses, for the report text: ``eps_final``, ``eps_blend``
    (where a count moved from the previous one is moved), ``perturb_at_eps`` (J2 switched on) and
    ``model_step_at_eps`` (the force model changed), the last two ε_f where the case leaves them out;
    ``switching`` (:func:`case_switching`): 'exact' where the route runs on the exact bang-bang map."""
    eps_f = float(pc["numerics"]["eps_final"])
    return {"eps_final": eps_f, "eps_blend": float(pc["numerics"]["eps_blend"]), "switching": case_switching(pc, "e8"),
            **{key: eps if eps is not None else eps_f
               for key, eps in (("perturb_at_eps", perturb_at_eps(pc, "e8")),
                                ("model_step_at_eps", perturb_at_eps(pc, "e8", "model_step_at_eps")))}}


def e8_model_steps(pc: dict) -> list[dict]:
    """The force-model steps of the E8 route after J2 is switched on (the case's models from the
    third on), for the report text: {model, from, from_at_n_rev, path, arcs, step_rcond,
    flat_step} from the case options ``model_from``, ``model_step`` and ``path_arcs``; ``from`` is
    the start model (:func:`case_start_model`) where it is not the one before in the list, else
    None; ``from_at_n_rev`` ({count: start model}) the counts of ``perturbed.e8.n_rev`` whose
    start differs from that (``model_from``'s ``at_n_rev``)."""
    cc, where = pc["cases"]["e8"], "perturbed.cases.e8"
    steps = []
    for model in cc["models"][2:]:
        step, start = case_model_step(cc, model, where), case_start_model(pc, "e8", model)
        at_n_rev = {float(n): s for n in pc["e8"]["n_rev"] if (s := case_start_model(pc, "e8", model, n)) != start}
        steps.append({"model": model, "from": None if start == cc["models"][cc["models"].index(model) - 1] else start,
                      "from_at_n_rev": at_n_rev,
                      "path": step.get("path", "tau"), "arcs": case_path_arcs(cc, model, where),
                      "step_rcond": step.get("step_rcond", 0.0), "flat_step": step.get("flat_step", 0.0)})
    return steps


def e8_runs(pc: dict) -> list[tuple[str, float]]:
    """(model, n_rev) of the E8 solves the tables ask for (the solves they start from come with
    them): ``perturbed.e8.run_models`` (default: the case's models) × ``run_n_rev``, less the
    counts ``skip_n_rev`` names for a model (counts whose route is known not to converge, each
    with its measured reason in the config; counts that are not run anyway are ignored, so a
    profile with fewer counts, e.g. the quick one, keeps the map). Checked: the run models are
    models of the case, the run counts lie on the ``n_rev`` grid, and the skipped models are run
    models."""
    e8, models = pc["e8"], pc["cases"]["e8"]["models"]
    run_models = e8.get("run_models", models)
    for m in run_models:
        if m not in models:
            raise ConfigError("perturbed.e8.run_models", m, f"not a model of case e8 (expected one of {', '.join(models)})")
    grid = [float(n) for n in e8["n_rev"]]
    counts = [float(n) for n in e8["run_n_rev"]]
    for n in counts:
        if n not in grid:
            raise ConfigError("perturbed.e8.run_n_rev", n, "not a count of perturbed.e8.n_rev")
    skip = {}
    for m, ns in (e8.get("skip_n_rev") or {}).items():
        if m not in run_models:
            raise ConfigError(f"perturbed.e8.skip_n_rev.{m}", ns, "not a model of perturbed.e8.run_models")
        skip[m] = {float(n) for n in ns}
    return [(m, n) for m in run_models for n in counts if n not in skip.get(m, ())]


def e8_skipped(pc: dict) -> list[tuple[str, float]]:
    """(model, n_rev) of the run list that ``skip_n_rev`` leaves out (:func:`e8_runs`), for the
    paper text: the tables have no row for them."""
    runs = set(e8_runs(pc))
    return [r for r in e8_runs({**pc, "e8": {**pc["e8"], "skip_n_rev": None}}) if r not in runs]


# ---------------------------------------------------------------- the existence check

def existence_from_ot(pc: dict) -> dict[str, dict]:
    """{case: the options of ``spaceopt.indirect.tmin_from_ot.FromOtOptions``} for the cases of
    ``perturbed.existence.from_ot``, whose check starts from their OT solution."""
    from_ot = dict((pc.get("existence") or {}).get("from_ot") or {})
    cases = from_ot.pop("cases", [])
    return {c: from_ot for c in cases}


def existence_bound_from(pc: dict) -> dict[tuple[str, str], str]:
    """{(case, model): the model whose upper bound the check of ``model`` carries over}
    (``perturbed.existence.bound_from``, ``spaceopt.indirect.tmin_from_ot.bound_in_model``).
    Cases that are not run are left out. Checked: the case is a from_ot case, and both are
    perturbed models of its check, not the same."""
    out = {}
    from_ot, runs = existence_from_ot(pc), existence_runs(pc)
    for c, pairs in ((pc.get("existence") or {}).get("bound_from") or {}).items():
        key = f"perturbed.existence.bound_from.{c}"
        if c not in from_ot:
            raise ConfigError(key, pairs, "not a case of perturbed.existence.from_ot")
        if c not in pc["run"]:
            continue
        models = [m for cc, m in runs if cc == c and m != "unperturbed"]
        for model, source in pairs.items():
            for m in (model, source):
                if m not in models:
                    raise ConfigError(f"{key}.{model}", m, f"not a perturbed model of the check (expected one of "
                                                           f"{', '.join(models)})")
            if model == source:
                raise ConfigError(f"{key}.{model}", source, "a model cannot carry over its own bound")
            out[(c, model)] = source
    return out


def existence_runs(pc: dict) -> list[tuple[str, str]]:
    """(case, model) of the minimum-thrust existence check (``perturbed.existence``): each listed
    case that is run, unperturbed first and then the case's models, less those ``skip`` names.
    Checked: the skipped models are models of the check, the from_ot cases are listed cases."""
    ex = pc.get("existence") or {}
    cases = [c for c in ex.get("cases", []) if c in pc["run"]]
    for c in existence_from_ot(pc):
        if c not in ex.get("cases", []):
            raise ConfigError("perturbed.existence.from_ot.cases", c, "not a case of perturbed.existence.cases")
    runs = {c: list(dict.fromkeys(["unperturbed", *pc["cases"][c]["models"]])) for c in cases}
    skip = ex.get("skip") or {}
    for c, models in skip.items():
        for m in models:
            if c in runs and m not in runs[c]:
                raise ConfigError(f"perturbed.existence.skip.{c}", m,
                                  f"not a model of the check (expected one of {', '.join(runs[c])})")
    return [(c, m) for c in cases for m in runs[c] if m not in skip.get(c, [])]
