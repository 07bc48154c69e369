"""The minimum-thrust existence check under each force model (spaceopt.studies.existence): the
table row from an artifact and the paper's sentence. The solves themselves run in the quick
reproduction (E9: test_quick_reproduction)."""
from spaceopt.studies import existence as E
from spaceopt.studies.perturbed_report import MODEL_TEX


def _payload(T_min, thrust, n_rev, tof=60.0, lp_perturbed=False):
    exists = thrust >= T_min
    return {"extra": {"verdict": {"T_min_N": T_min, "thrust_N": thrust, "exists": exists, "n_rev": n_rev,
                                  "n_rev_needed_estimate": n_rev * T_min / thrust},
                      "lp_perturbed": lp_perturbed},
            "scalars": {"tof_days": tof, "K_f_deg": 1818.0}}


def test_a_row_carries_the_verdict_of_the_artifact():
    row = E.row("e9", "j2", _payload(0.0361, 1.0, 63.007, lp_perturbed=True))
    assert list(row) == list(E.COLUMNS)
    assert row["exists"] is True and row["n_rev_needed"] == 63.007 * 0.0361 and row["lp_perturbed"] is True


def test_the_sentence_gives_each_change_and_where_the_verdict_turns():
    rows = [E.row("e9", m, _payload(t, 1.0, 63.007)) for m, t in
            (("unperturbed", 4.533), ("j2", 0.03614), ("g44_moon_sun", 0.03482))]
    rows += [E.row("e5", m, _payload(t, 0.5, 5.0)) for m, t in (("unperturbed", 0.2002), ("g44_moon_sun", 0.2152))]
    rows = [{k: (str(v) if k == "exists" else v) for k, v in r.items()} for r in rows]     # as read from the CSV
    text = E.sentence(rows, MODEL_TEX)
    assert "E9 (63.007 revolutions, $T = 1$~N): unperturbed 4.533~N; $J_2$ 0.03614~N ($\\times0.00797$)" in text
    assert ("the thrust is below $T_{min}$ for unperturbed (no transfer over this angular range; about 286 "
            "revolutions would be needed) and above it for $J_2$, 4$\\times$4 + Moon + Sun") in text
    assert "E5 (5 revolutions, $T = 0.5$~N): unperturbed 0.2002~N; 4$\\times$4 + Moon + Sun 0.2152~N (+7.5\\,\\%)" in text
    assert text.count("below $T_{min}$") == 1                     # E5 exists under both models
    none = E.sentence([{**rows[0], "exists": "False"}, {**rows[1], "exists": "False"}], MODEL_TEX)
    assert "below $T_{min}$ for unperturbed, $J_2$: no transfer over this angular range" in none
    assert E.sentence([], MODEL_TEX) == ""


def test_an_upper_bound_is_written_as_one_and_decides_only_at_or_above_it():
    """E7's rows come from the OT side (tmin_from_ot) and are upper bounds: "≤", no change
    against another bound, the route named; a thrust below a bound is undecided, not "no
    transfer"."""
    def bound(model, T_min, thrust):
        p = _payload(T_min, thrust, 100.0)
        p["extra"]["verdict"].update(T_min_is="upper bound", exists=True if thrust >= T_min else None)
        p["extra"]["route"] = "ot-tmin"
        return E.row("e7", model, p)
    rows = [bound("unperturbed", 0.311622, 1.0), bound("j2", 0.309901, 1.0)]
    assert rows[0]["T_min_is"] == "upper bound" and rows[0]["route"] == "ot-tmin"
    rows = [{k: ("" if v is None else str(v)) if k == "exists" else v for k, v in r.items()} for r in rows]
    text = E.sentence(rows, MODEL_TEX)
    assert "E7 (100 revolutions, $T = 1$~N): unperturbed $\\le$ 0.3116~N; $J_2$ $\\le$ 0.3099~N (upper bounds" in text
    assert "below" not in text.split("(upper bounds")[0]
    low = E.sentence([bound("unperturbed", 0.311622, 0.2)], MODEL_TEX)
    assert "below the upper bound for unperturbed: undecided" in low and "no transfer" not in low


def test_a_bound_carried_over_from_another_model_names_its_source():
    """existence.bound_from (E7 full model): the row records the source model, the sentence says
    whose bound it is and why."""
    p = _payload(0.3111, 1.0, 100.0)
    p["extra"]["verdict"].update(T_min_is="upper bound")
    p["extra"].update(route="ot-tmin-model", bound_from="j2")
    row = E.row("e7", "g44_moon_sun", p)
    assert row["bound_from"] == "j2" and row["route"] == "ot-tmin-model"
    assert E.row("e7", "j2", _payload(0.3110, 1.0, 100.0))["bound_from"] == ""
    text = E.sentence([row], MODEL_TEX)
    assert f"the bound for {MODEL_TEX['g44_moon_sun']} is that for {MODEL_TEX['j2']} carried over" in text
