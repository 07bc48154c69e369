"""D1 step: the three schemes of the GEO insertion study (spec 05-discrete.md §D1).

Snakemake script: params.cfg (the geo_burns config section), params.rel_published (case prefix
of the published file); input.published; output: csv, grid, sensitivity, json, switching (npz),
reproduction, hypotheses (readings of the source tested against the published classical scheme),
figures dir. All physics in spaceopt.discrete.geo_burns.
"""
import sys
import time
from contextlib import redirect_stderr
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

import numpy as np  # noqa: E402

from spaceopt.report.tables import write_csv  # noqa: E402
from spaceopt.artifacts import provenance, write_json, write_npz  # noqa: E402
from spaceopt.discrete import geo_burns as gb  # noqa: E402
from spaceopt.report.compare import COLUMNS, compare, published_lookup, write_rows  # noqa: E402
from spaceopt.report.figures import save_figure  # noqa: E402


def main(sm):
    t_start = time.time()
    cfg = sm.params.cfg
    pub = published_lookup(sm.input.published)
    counts = (int(pub[("d1_classical", "perigee_burns")]["value"]),
              int(pub[("d1_classical", "apogee_burns")]["value"]))
    print("D1: scheme grid ...", file=sys.stderr)
    res = gb.run_study(cfg, published_counts=counts)
    recs, schemes = res["records"], res["schemes"]
    order = ["classical", "start_penalised", "flown", "classical_published_counts"]
    write_csv(sm.output.csv, [gb.csv_row(recs[n]) for n in order], gb.GEO_CSV_COLUMNS)
    write_csv(sm.output.grid, res["grid"], ["n_p", "n_a", "time_s", "fuel_kg", "terminal_penalty_kg",
                                             "cost_classical_kg", "cost_penalised_kg", "feasible"])
    sens_cols = ["mass_flow_kg_s"] + gb.GEO_CSV_COLUMNS + ["final_ecc", "rho_t1_miss_m"]
    write_csv(sm.output.sensitivity, [dict(gb.csv_row(r), mass_flow_kg_s=r["mass_flow_kg_s"],
                                            final_ecc=r["final_ecc"], rho_t1_miss_m=r["rho_t1_miss_m"])
                                       for r in res["sensitivity"]], sens_cols)

    # switching function along the optimised schemes
    nsamp = int(cfg["numerics"]["switching_samples_per_arc"])
    sw, arrays = {}, {}
    figdir = Path(sm.params.figdir)
    for name in ("classical", "start_penalised", "classical_published_counts"):
        print(f"D1: switching function along {name} ...", file=sys.stderr)
        k = gb.switching_function(schemes[name], nsamp, float(cfg["numerics"]["switching_sample_dt_s"]))
        sw[name] = {key: v for key, v in k.items() if key not in ("t", "k", "burn")}
        arrays.update({f"{name}_t_s": k["t"], f"{name}_k": k["k"], f"{name}_burn": k["burn"]})
        s = schemes[name]
        save_figure(gb.plot_switching(k, f"D1 {name}: switching function k(t), "
                                         f"{s.n_p}+{s.n_a} burns (thrust where k >= 1)"),
                    figdir / f"geo_switching_{name}.png")
    for name in order:
        save_figure(gb.plot_orbit_sequence(schemes[name]), figdir / f"geo_orbits_{name}.png")
    write_npz(sm.output.switching, **arrays)

    # reproduction rows (D1 part of the published file)
    c, cp, fl = recs["classical"], recs["classical_published_counts"], recs["flown"]
    ours = {("d1_classical", q): c[q] for q in ("burns", "perigee_burns", "apogee_burns", "time_s", "fuel_kg")}
    ours.update({("d1_classical_published_counts", "perigee_burn_s"): cp["perigee_burn_s"][0],
                 ("d1_classical_published_counts", "perigee_last_burn_s"): cp["perigee_burn_s"][-1],
                 ("d1_classical_published_counts", "apogee_burn_s"): cp["apogee_burn_s"][0],
                 ("d1_classical_published_counts", "apogee_last_burn_s"): cp["apogee_burn_s"][-1],
                 ("d1_classical_published_counts", "time_s"): cp["time_s"],
                 ("d1_classical_published_counts", "fuel_kg"): cp["fuel_kg"],
                 ("d1_classical_published_counts", "max_apse_rotation_deg"): cp["max_apse_rotation_deg"],
                 ("d1_flown", "fuel_kg"): fl["fuel_kg"],
                 ("d1_flown", "fuel_with_penalty_kg"): fl["fuel_with_penalty_kg"],
                 ("d1_flown", "starts_within_stage_limit"):
                     "yes" if fl["burns"] <= int(cfg["flown"]["max_starts"]) else "no"})
    sens = {(r["scheme"], r["mass_flow_kg_s"]): r for r in res["sensitivity"]}
    flows = sorted({r["mass_flow_kg_s"] for r in res["sensitivity"]})

    def at_flows(scheme, key, fmt="{:.1f}"):
        return "; ".join(f"at {f:g} kg/s: " + (fmt.format(sens[(scheme, f)][key]) if not isinstance(
            sens[(scheme, f)][key], list) else "/".join(f"{d:.1f}" for d in sens[(scheme, f)][key]))
                         for f in flows if (scheme, f) in sens)

    flow_o, flow_f = c["mass_flow_kg_s"], fl["mass_flow_kg_s"]

    # readings of the source tested against the published classical scheme
    def pv(q, case="d1_classical"):
        return float(pub[(case, q)]["value"])

    target = {"n_p": counts[0], "n_a": counts[1], "time_s": pv("time_s"), "fuel_kg": pv("fuel_kg"),
              "max_apse_rotation_deg": pv("max_apse_rotation_deg", "d1_classical_published_counts")}
    hyp = gb.hypothesis_table(res, cfg, target)
    write_csv(sm.output.hypotheses, hyp, gb.HYPOTHESIS_COLUMNS)
    timed = [h for h in hyp if isinstance(h["time_s"], float)]
    near_pc = min((h for h in timed if h["counts"].startswith("imposed")),
                  key=lambda h: abs(h["time_minus_published_s"]))
    sel = [h for h in timed if h["counts"] == "selected"]
    counts_seen = sorted({(h["perigee_burns"], h["apogee_burns"]) for h in sel})
    rot = {h["hypothesis"]: h["max_apse_rotation_deg"] for h in hyp if h["hypothesis"].startswith("H4_")}
    why_time = (f"our coast arcs are exact Kepler times between apsides; at the published counts the "
                f"published time is {target['time_s'] - cp['time_s']:.0f} s (~{(target['time_s'] - cp['time_s']) / 86164:.2f} "
                f"GEO periods) longer than the published burn structure takes in this model. "
                f"{len(hyp)} readings tested (geo_burns_hypotheses.csv: time bookkeepings, mass flows, "
                f"count rules): none reproduces; closest at the published counts: {near_pc['hypothesis']} "
                f"{near_pc['time_s']:.0f} s ({near_pc['time_minus_published_s']:+.0f} s, no support in the "
                f"spec's text); erratum: the published 725033 s is inconsistent with Kepler arcs between "
                f"the published 18 burns")
    notes = {
        ("d1_classical", "burns"): (f"our optimum over n_p in {cfg['search']['perigee_burns']}, n_a in "
                                    f"{cfg['search']['apogee_burns']} at {flow_o:g} kg/s, subject to time <= t1; "
                                    "fuel falls monotonically with the number of perigee burns, so the "
                                    "count is set by t1, and with exact Kepler coasts t1 admits more burns "
                                    "than the paper's bookkeeping did; counts selected by the tested "
                                    "readings: " + ", ".join(f"{a}+{b}" for a, b in counts_seen)
                                    + f" (never {counts[0]}+{counts[1]}: in this model trading an apogee burn "
                                    "for a perigee burn lowers fuel unless it leaves a single apogee burn, and "
                                    "the apogee-burn count barely changes fuel; see docs/d1-geo-burns.md); "
                                    + why_time),
        ("d1_classical", "perigee_burns"): "see burns",
        ("d1_classical", "apogee_burns"): "see burns",
        ("d1_classical", "time_s"): (f"time of our optimum ({c['perigee_burns']}+{c['apogee_burns']} burns); t1 = "
                                     f"{cfg['model']['t1_s']:g} s binds both ours and the paper's optimum, so the "
                                     "closeness of the two times reflects the constraint, not the same schedule"),
        ("d1_classical", "fuel_kg"): f"mass flow {flow_o:g} kg/s; " + at_flows("classical", "fuel_kg"),
        ("d1_classical_published_counts", "perigee_burn_s"):
            f"mass flow {flow_o:g} kg/s; perigee burns " + at_flows("classical_published_counts", "perigee_burn_s"),
        ("d1_classical_published_counts", "apogee_burn_s"):
            f"mass flow {flow_o:g} kg/s; apogee burns " + at_flows("classical_published_counts", "apogee_burn_s"),
        ("d1_classical_published_counts", "time_s"): why_time,
        ("d1_classical_published_counts", "fuel_kg"):
            f"mass flow {flow_o:g} kg/s (the paper's implied flow); " + at_flows("classical_published_counts", "fuel_kg"),
        ("d1_classical_published_counts", "max_apse_rotation_deg"):
            "ours: angle between the new apse line and the vehicle's polar angle at the burn's mid time, "
            "largest over burns (the last perigee burn); the paper's definition is not given; other "
            "definitions: " + "; ".join(f"{k[3:]} {v:.3f} deg" for k, v in rot.items())
            + " (none within 5 %); 0.273 has the digits of the 273 s perigee burn (possibly a "
            "transcription slip)",
        ("d1_flown", "fuel_kg"): f"mass flow {flow_f:g} kg/s; " + at_flows("flown", "fuel_kg"),
        ("d1_flown", "fuel_with_penalty_kg"): f"fuel + lambda3 * 3 starts; mass flow {flow_f:g} kg/s",
    }
    ours = {k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in ours.items()}
    rows = [r for r in compare(sm.input.published, ours, notes) if r["case"].startswith("d1_")]
    # held-back published values (start-penalised scheme): our numbers, marked as such
    sp = recs["start_penalised"]
    held = [("burns", sp["burns"], ""), ("perigee_burns", sp["perigee_burns"], ""),
            ("apogee_burns", sp["apogee_burns"], ""),
            ("perigee_burn_s", "/".join(f"{d:.2f}" for d in sp["perigee_burn_s"]), "s"),
            ("apogee_burn_s", "/".join(f"{d:.2f}" for d in sp["apogee_burn_s"]), "s"),
            ("time_s", sp["time_s"], "s"), ("fuel_kg", sp["fuel_kg"], "kg"),
            ("fuel_with_penalty_kg", sp["fuel_with_penalty_kg"], "kg"),
            ("saving_vs_classical_with_penalty_kg", c["fuel_with_penalty_kg"] - sp["fuel_with_penalty_kg"], "kg"),
            ("saving_vs_classical_published_counts_with_penalty_kg",
             cp["fuel_with_penalty_kg"] - sp["fuel_with_penalty_kg"], "kg"),
            ("extra_fuel_vs_classical_kg", sp["fuel_kg"] - c["fuel_kg"], "kg"),
            ("saving_vs_flown_with_penalty_kg", fl["fuel_with_penalty_kg"] - sp["fuel_with_penalty_kg"], "kg")]
    for q, v, unit in held:
        rows.append({k: "" for k in COLUMNS} | {
            "study": "discrete_geo_bellman", "case": "d1_start_penalised", "quantity": q, "unit": unit,
            "published": "held back", "ours": float(v) if isinstance(v, np.floating) else v,
            "status": "info",
            "ref": "05-discrete.md §D1, Problem 2 (values held back)",
            "note": f"lambda3 = {res['lambda3']:g} kg per start, mass flow {flow_o:g} kg/s; "
                    "fuel_with_penalty = fuel + lambda3 * starts"})
    write_rows(sm.output.reproduction, rows)

    payload = {
        "study": "geo_burns", "units": "SI (m, s, kg, rad; angles in tables in deg)",
        "schemes": recs, "switching_check": sw, "optimum_at_search_edge": res["optimum_at_search_edge"],
        "sensitivity": res["sensitivity"],
        "method": "approximate method of the paper: Kepler coasts, burns centred on apsides "
                  "integrated with scipy RK45 (Dormand-Prince 5(4)); integer-second burn durations, "
                  "last burn of each series trimmed with brentq",
        "provenance": provenance(cfg, time.time() - t_start),
    }
    write_json(sm.output.json, payload, companions={"switching": sm.output.switching})
    print(f"D1: done in {time.time() - t_start:.1f} s", file=sys.stderr)


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as _log, redirect_stderr(_log):  # noqa: F821
        run_step(main, snakemake)  # noqa: F821
