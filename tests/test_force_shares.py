"""What each force contributes (spaceopt.studies.force_shares): the table rows, the paper's
sentence, the E6 figure and its caption. The budget itself is computed on a real perturbed
artifact in tests/test_cli.py (it needs a perturbed solve)."""
import pytest

from spaceopt.studies import force_shares as S


def _payload(artifact, m_f, moon, sun=0.2, closure=1e-8, closest_km=1.0e5):
    thrust = 1.0 - moon - sun - 1e-4
    return {"artifact": artifact, "scalars": {"m_f_kg": m_f, "tof_days": 60.0},
            "force_shares": {"forces": ["thrust", "geopotential", "moon", "sun"],
                             "h_share": {"thrust": thrust, "geopotential": 1e-4, "moon": moon, "sun": sun},
                             "E_share": {"thrust": 1.02, "geopotential": 0.01, "moon": -0.04, "sun": 0.01},
                             "delta_h_m2_s": 2.0e10, "h0_m2_s": 1.0e10, "delta_E_m2_s2": -7.0e5,
                             "closure_h": closure, "closure_E": 2 * closure,
                             "moon_closest_km": closest_km, "moon_closest_days": 20.0,
                             "revolutions": [{"start_days": 0.0, "end_days": 25.0,
                                              "h_share": {"thrust": thrust - 0.1, "moon": 0.8 * moon}},
                                             {"start_days": 25.0, "end_days": 60.0,
                                              "h_share": {"thrust": 0.1, "moon": 0.2 * moon}}]}}


def test_a_row_carries_every_force_of_its_solve_in_the_table_order():
    e9 = _payload("e9/j2", 999.3, 0.0)
    e9["force_shares"].update(forces=["thrust", "geopotential"])         # no third bodies
    rows = [S.share_row(_payload("e6/2021-05-01", 957.0, 0.1)), S.share_row(e9)]
    assert "h_share_moon" not in rows[1] and rows[1]["h_share_geopotential"] == 1e-4
    assert rows[0]["delta_h_over_h0"] == 2.0 and rows[0]["h_share_moon"] == 0.1
    cols = S.share_columns(rows)
    assert cols[:5] == ["artifact", "m_f_kg", "tof_days", "delta_h_over_h0", "delta_E_m2_s2"]
    assert cols[5:7] == ["h_share_thrust", "E_share_thrust"]
    assert cols[-4:] == ["moon_closest_km", "moon_closest_days", "closure_h", "closure_E"]
    assert cols.index("h_share_geopotential") < cols.index("h_share_moon") < cols.index("h_share_sun")
    assert "h_share_j2" not in cols                       # no row has it


def test_the_sentence_gives_the_e6_ranges_and_how_the_final_mass_goes_with_the_moons_share():
    e6 = [S.share_row(_payload(f"e6/2021-05-0{k}", m, moon, closest_km=3e5 - 4e5 * moon))
          for k, (m, moon) in enumerate(((956.5, 0.1), (958.5, 0.3), (960.5, 0.5)), start=1)]
    other = S.share_row(_payload("e5/g44_moon_sun", 957.5, 0.214, closure=3e-8))
    text = S.shares_sentence(e6 + [other], unperturbed_m_f=956.13)
    assert "closes to 6.0e-08" in text                     # the worst closure of all rows
    assert "Over the 3 E6 dates the thrust supplies 30 to 70 % of Δh" in text
    assert "the geopotential less than 0.5 %, the Moon 10 to 50 %, the Sun 20 to 20 %" in text
    assert "the thrust supplies 102 to 102 % of ΔE" in text
    assert "The final mass rises with the Moon's share: correlation 1.00" in text
    assert "+1.00 kg per 10 % of Δh and 955.50 kg at no lunar share (unperturbed: 956.13 kg)" in text
    assert "(closest approach 100,000 to 260,000 km): correlation -1.00." in text
    assert ("Elsewhere (share of Δh; of ΔE, the thrust's): e5/g44_moon_sun: the thrust 58.6 %, the geopotential "
            "0.0 %, the Moon 21.4 %, the Sun 20.0 %; 102.0 % of ΔE.") in text
    e8 = [S.share_row(_payload(f"e8/g44_moon_sun_n{n}.json", 150.0, moon)) for n, moon in ((200, 0.001), (500, 0.002))]
    e8[1]["E_share_thrust"] = 1.008
    assert ("e8/g44_moon_sun (2 counts): the thrust 79.8 to 79.9 %, the geopotential 0.0 %, the Moon 0.1 to 0.2 %, "
            "the Sun 20.0 %; 100.8 to 102.0 % of ΔE.") in S.shares_sentence(e8)
    assert "gathered mostly in one revolution" not in text          # without the table by revolution
    revs = [r for p in (_payload("e6/2021-05-03.json", 960.5, 0.5),) for r in S.revolution_rows(p)]
    assert [r["revolution"] for r in revs] == [1, 2] and revs[0]["h_share_moon"] == pytest.approx(0.4)
    assert S.revolution_columns(revs) == ["artifact", "revolution", "start_days", "end_days", "h_share_thrust",
                                          "h_share_moon"]
    e6[2]["artifact"] = "e6/2021-05-03.json"
    with_revs = S.shares_sentence(e6, revolutions=revs)
    assert ("It is gathered mostly in one revolution: at 2021-05-03, 40 of its 50 % in revolution 1 of 2 "
            "(days 0.0 to 25.0;") in with_revs
    falling = S.shares_sentence([S.share_row(_payload(f"e6/2021-05-0{k}", 960.0 - k, 0.1 * k)) for k in (1, 2, 3)])
    assert "The final mass falls with the Moon's share" in falling and "unperturbed" not in falling
    flat = _payload("e6/2021-05-01", 957.0, 0.1)              # ΔE below MIN_CHANGE: no E shares
    flat["force_shares"]["E_share"] = dict.fromkeys(flat["force_shares"]["E_share"])
    assert "of ΔE" not in S.shares_sentence([S.share_row(flat)]) and S.share_row(flat)["E_share_moon"] is None
    assert S.shares_sentence([]) == ""
    assert "E6" not in S.shares_sentence([other])


def test_the_e6_figure_draws_the_shares_by_date_and_the_mass_against_the_moons_share(tmp_path, monkeypatch):
    from spaceopt.studies import perturbed_figures as F
    drawn = []
    monkeypatch.setattr(F, "save_figure", lambda fig, path: drawn.append(
        [[(ln.get_label(), list(ln.get_xdata()), list(ln.get_ydata())) for ln in ax.lines] for ax in fig.axes]))
    rows = [{**S.share_row(_payload(f"e6/2021-05-{d:02d}", m, moon)), "h_share_j2": ""}   # as read from
            for d, m, moon in ((12, 960.5, 0.5), (2, 956.5, 0.1))]          # the CSV; unsorted: drawn by date
    F.force_shares_vs_date(rows, 956.13, tmp_path / "fs", heavier=[{"h_share_moon": 0.55, "m_f_kg": 961.0}])
    left, right = drawn[0]
    moon = next(ln for ln in left if ln[0] == "moon")
    assert moon[1:] == ([2, 12], [pytest.approx(10.0), pytest.approx(50.0)])
    assert {ln[0] for ln in left} == {"thrust", "geopotential", "moon", "sun"}
    points = next(ln for ln in right if ln[0] == "perturbed extremal of a date")
    assert points[1:] == ([pytest.approx(10.0), pytest.approx(50.0)], [956.5, 960.5])
    fit = next(ln for ln in right if ln[0].startswith("least squares"))
    assert fit[0] == "least squares, +1.00 kg per 10 %" and fit[2][0] == pytest.approx(955.5)
    assert any(ln[2] == [956.13, 956.13] for ln in right)          # the unperturbed line
    assert next(ln for ln in right if ln[0] == "another family's heavier extremal")[1:] == ([pytest.approx(55.0)], [961.0])
    no_moon = [{k: v for k, v in r.items() if "moon" not in k} for r in rows]     # E6 without the Moon
    F.force_shares_vs_date(no_moon, 956.13, tmp_path / "fs")
    left, right = drawn[1]
    assert "moon" not in {ln[0] for ln in left} and right == []


def test_a_figure_not_in_the_dissertation_is_not_captioned_as_one():
    from spaceopt.studies import perturbed_report as R
    smoothing = {"eps_final": 1e-5, "eps_blend": 1e-2, "perturb_at_eps": 1e-2, "model_step_at_eps": 1e-2}
    tex = R.paper_section([], {}, None, {}, ["x/fig_4_2_1_4.pdf", "x/fig_e6_force_shares.pdf"],
                          e8_count_start="chain", smoothing=smoothing, e8_steps=[],
                          force_shares="What each force contributes: 50 % of Δh.")
    assert "(dissertation Fig. 4.2.1.4).}" in tex
    assert "(not in the dissertation).}" in tex and "dissertation Fig. e6" not in tex
    assert r"What each force contributes: 50 \% of \ensuremath{\Delta}h." in tex
