"""The free-time end game (spaceopt.indirect.free_time): a local maximum of the final mass along
the fixed-time family, first on model families m_f(t_f) whose φ = −dm_f/dt_f is known, then on
a perturbed 2-revolution transfer (E1 orbits, EGM96 2×2 with the Earth's rotation: H depends on t)."""
import dataclasses

import numpy as np
import pytest

from spaceopt.indirect import free_time as ft
from spaceopt.indirect.continuation import ContinuationOptions

QUIET = ContinuationOptions(verbose=False)


class ModelFamily:
    """A fixed-time family with z = (t_f, 0) and a given φ(t_f); ``fails_above``: Newton fails
    there; ``fails_once``: at these t_f the first solve fails. m_f is φ's antiderivative with a minus sign (the envelope relation dm_f/dt_f = −φ)."""

    def __init__(self, phi, mass, fails_above=np.inf, probe_days=1.0, fails_once=()):
        self.phi, self.mass, self.fails_above, self.fails_once = phi, mass, fails_above, set(fails_once)
        self.opt = ft.MaximumOptions(probe_days=probe_days, tof_tol_days=1e-9, verbose=False)
        self.e_t = np.array([0.0, 1.0])
        self.eps = self.eps_f = 1e-5
        self.calls = []

    def point(self, tf, z, J=None):
        self.calls.append(tf)
        if tf > self.fails_above or tf in self.fails_once:
            self.fails_once.discard(tf)
            return None
        return ft.FixedTimePoint(tf, np.array([tf, 0.0]), np.eye(2), self.mass(tf), self.phi(tf))

    def correct(self, x_pred, border=None, J=None):
        """The arclength corrector: this family is t_f itself, a step fails where Newton does."""
        return self.point(x_pred[-1], x_pred[:-1], J)

    def tangent(self, p):
        return np.array([1.0, 0.0, 1.0])


class FoldFamily(ft.FixedTimeFamily):
    """A family that folds in t_f, solved by the library's own corrector: z = (u, w),
    F(z, t_f) = (w + T(u), −w − t_f), the time row second (as p_t(K_f) ↦ t(K_f) − t_f) and the
    nonlinear row first (the time row is left out of the corrector's |f|). Its points are
    w = −T(u), t_f = T(u), with folds where T′(u) = 0 and ∂F/∂z is singular. The default
    T = −u²: two branches u < 0 and u > 0 for t_f < 0, none above, the fold at u = 0. φ(u) is
    given and m_f(u) = −∫ φ dt_f/du du (the envelope relation along the family)."""

    def __init__(self, phi, mass, probe_days=0.04, shape=(lambda u: -u * u, lambda u: -2.0 * u), max_points=16):
        self.opt = ft.MaximumOptions(probe_days=probe_days, tof_tol_days=1e-9, verbose=False, max_points=max_points)
        self.phi_of, self.mass_of = phi, mass
        self.T, self.dT = shape
        self.e_t = np.array([0.0, 1.0])
        self.eps = self.eps_f = 1e-5
        self.jacobians = self.residuals = self.solves = 0

    def evaluate(self, z, tf, jacobian):
        u, w = z
        self.residuals += not jacobian
        self.jacobians += jacobian
        J = np.array([[self.dT(u), 1.0], [0.0, -1.0]]) if jacobian else None
        return np.array([w + self.T(u), -w - tf]), J, True

    def _point(self, tf, z, J):
        return ft.FixedTimePoint(tf, z, J, self.mass_of(z[0]), self.phi_of(z[0]))

    def start(self, u):
        return self.T(u), np.array([u, -self.T(u)])


def search(family, t0):
    s = ft.MaximumSearch(family, tu=ft.DAY, m0_kg=1.0)      # time unit = 1 day
    origin = s.solve(t0, np.array([t0, 0.0]))
    found = s.bracket(origin)
    return s, found, (None if isinstance(found, str) else s.root(*found)[0])


def test_a_maximum_at_the_solution_is_certified_by_the_probes():
    fam = ModelFamily(lambda t: 2 * (t - 1.0), lambda t: -(t - 1.0) ** 2)
    s, (left, right), best = search(fam, 1.0 + 1e-7)
    assert left.phi < 0 < right.phi and right.tf - left.tf <= 1.0
    assert abs(best.tf - 1.0) < 1e-8


def test_from_an_inflection_the_march_goes_uphill_to_the_maximum():
    """φ = (t − 1)²(t − 3): a double root at t₀ = 1 (an inflection of m_f, the degenerate point
    a free-time Newton accepts: E8 250 rev), φ < 0 on both probes; the maximum is at 3."""
    phi = lambda t: (t - 1.0) ** 2 * (t - 3.0)
    mass = lambda t: -((t - 1.0) ** 4 / 4 - 2.0 * (t - 1.0) ** 3 / 3)
    fam = ModelFamily(phi, mass, probe_days=0.3)
    s, (left, right), best = search(fam, 1.0)
    assert left.phi < 0 < right.phi and left.tf < 3.0 < right.tf
    assert abs(best.tf - 3.0) < 1e-8 and mass(best.tf) > mass(1.0)
    assert min(fam.calls) == pytest.approx(0.7)            # one probe below, then upwards only


def test_from_a_local_minimum_the_heavier_side_is_taken():
    """φ = (t − 1)(t − 2)(t − 3.5): maxima of m_f at 1 and 3.5, a minimum at 2; m_f is higher at
    the upper maximum, so the march leaves the minimum upwards."""
    phi = lambda t: (t - 1.0) * (t - 2.0) * (t - 3.5)
    mass = lambda t: -((t ** 4) / 4 - 6.5 * t ** 3 / 3 + 12.5 * t ** 2 / 2 - 7.0 * t)
    assert mass(3.5) > mass(1.0)
    fam = ModelFamily(phi, mass, probe_days=0.3)
    s, (left, right), best = search(fam, 2.0)
    assert abs(best.tf - 3.5) < 1e-8 and left.phi < 0 < right.phi


def test_a_probe_that_fails_is_retried_closer_and_the_march_goes_on_from_it():
    """Newton fails at the probe t₀ + δ (the E8 500 degenerate point, where the family bends):
    the probe is taken at δ/2, and the march starts from there with that spacing."""
    fam = ModelFamily(lambda t: t - 2.0, lambda t: -0.5 * (t - 2.0) ** 2, probe_days=0.3, fails_once={1.3})
    s, (left, right), best = search(fam, 1.0)
    assert abs(best.tf - 2.0) < 1e-8 and left.phi < 0 < right.phi
    assert fam.calls[:4] == [1.0, 0.7, 1.3, 1.15] and fam.calls[4] == pytest.approx(1.3)


def test_a_family_that_cannot_be_followed_is_reported_not_forced():
    """Newton fails beyond t = 1.4 before φ changes sign: the march halves its step to δ/8, then
    tries arclength steps, and stops with a reason."""
    fam = ModelFamily(lambda t: t - 2.0, lambda t: -0.5 * (t - 2.0) ** 2, fails_above=1.4, probe_days=0.25)
    s, found, best = search(fam, 1.0)
    assert isinstance(found, str) and "could not be followed" in found and "arclength" in found and best is None
    assert pytest.approx(1.375 + 0.25 / 8) in fam.calls                     # steps in t_f down to δ/8
    assert 1.4 - 0.25 / 8 / 8 < max(p.tf for p in s.points) <= 1.4      # arclength creeps up to it


# φ(u) = u (0.6 − u) on the fold family: φ < 0 on the branch u < 0, φ > 0 on u > 0 near the
# fold; the maximum of m_f is at u = 0.6 (t_f = −0.36), a crossing of φ from − to + in t_f.
FOLD_PHI = lambda u: u * (0.6 - u)
FOLD_MASS = lambda u: 2.0 * 0.6 * u ** 3 / 3.0 - u ** 4 / 2.0      # −∫ φ T′ du


def search_fold(fam, u0):
    t0, z0 = fam.start(u0)
    s = ft.MaximumSearch(fam, tu=ft.DAY, m0_kg=1.0)
    found = s.bracket(s.solve(t0, z0))
    return s, found, (None if isinstance(found, str) else s.root(*found)[0])


def test_arclength_goes_round_a_fold_from_the_downhill_branch():
    """The E8 500 situation met by Newton: the free-time extremal sits next to a fold of the
    fixed-time family (u₀ = −0.01, φ ≈ −0.006), the probe above it fails and the one below
    lands on the lighter branch. Arclength from the origin goes round the fold onto u > 0, then
    up that branch (t_f falling) to the maximum at u = 0.6."""
    fam = FoldFamily(FOLD_PHI, FOLD_MASS)
    s, (left, right), best = search_fold(fam, -0.01)
    assert s.folds == 1 and s.arc_points >= 2
    assert left.phi < 0.0 < right.phi and left.tf < right.tf and left.z[0] > 0.0 and right.z[0] > 0.0
    assert best.z[0] == pytest.approx(0.6, abs=1e-6) and best.tf == pytest.approx(-0.36, abs=1e-6)
    assert best.m_f > FOLD_MASS(-0.01)


def test_from_the_uphill_branch_past_a_fold_the_march_goes_on_in_t_f():
    """The same family from u₀ = +0.01, past the fold: the probe below lands on u > 0, heavier
    and uphill, and steps in t_f go on down to the maximum without arclength."""
    fam = FoldFamily(FOLD_PHI, FOLD_MASS)
    s, (left, right), best = search_fold(fam, 0.01)
    assert s.arc_points == 0 and best.z[0] == pytest.approx(0.6, abs=1e-6)


def test_a_fold_where_phi_keeps_its_sign_is_no_maximum_and_is_reported():
    """φ = −1 everywhere: m_f = T(u) rises up to the fold and falls beyond it. The march goes up
    in t_f, arclength rounds the fold and finds m_f falling: the search says so."""
    fam = FoldFamily(lambda u: -1.0, lambda u: -u * u)
    s, found, best = search_fold(fam, -0.3)
    assert isinstance(found, str) and "folds" in found and best is None and s.folds == 1


# t_f = u³ − u: folds at u = ∓1/√3, a maximum of t_f on the first and a minimum on the second;
# φ = u − 1.2 < 0 on both: m_f rises to the first fold, falls along the middle branch, rises
# past the second fold, and φ crosses from − to + in t_f at u = 1.2 (t_f 0.528), a maximum.
CUBIC = (lambda u: u ** 3 - u, lambda u: 3.0 * u * u - 1.0)
CUBIC_PHI = lambda u: u - 1.2
CUBIC_MASS = lambda u: -(0.75 * u ** 4 - 1.2 * u ** 3 - 0.5 * u * u + 1.2 * u)       # −∫ φ T′ du


@pytest.mark.parametrize("downhill_folds", [0, 1])
def test_past_a_fold_where_phi_keeps_its_sign_the_walk_goes_on_downhill_only_when_asked(downhill_folds):
    """The E8 450 situation: the branch through the start (u₀ = −0.7) rises in m_f to a fold
    with φ ≠ 0. The local end game stops there; with downhill_folds 1 the walk goes on down
    the middle branch, round the second fold, and up the third to its maximum, lighter than the
    first fold but a free-time extremal."""
    fam = FoldFamily(CUBIC_PHI, CUBIC_MASS, probe_days=0.02, shape=CUBIC, max_points=100)
    fam.opt = dataclasses.replace(fam.opt, downhill_folds=downhill_folds, max_arc_step=8.0)
    s, found, best = search_fold(fam, -0.7)
    if downhill_folds == 0:
        assert isinstance(found, str) and "folds" in found and best is None and s.folds == 1 and s.downhill == 0
        return
    left, right = found
    assert s.folds == 2 and s.downhill == 1 and left.phi < 0.0 < right.phi and left.tf < right.tf
    assert best.z[0] == pytest.approx(1.2, abs=1e-6) and best.tf == pytest.approx(1.2 ** 3 - 1.2, abs=1e-6)
    assert min(p.z[0] for p in s.points) < -1.0 / np.sqrt(3.0) < max(p.z[0] for p in s.points)


class FarSheetFamily(FoldFamily):
    """CUBIC, where the corrector of the first arclength step past u = 0.4 converges on a far
    sheet of the family (t_f 5 higher, lighter, φ > 0), as the exact map's E8 full 450 did
    near a fold: the hyperplane of a step there runs almost along t_f."""

    def __init__(self):
        super().__init__(CUBIC_PHI, CUBIC_MASS, probe_days=0.02, shape=CUBIC, max_points=100)
        self.opt = dataclasses.replace(self.opt, downhill_folds=1, max_arc_step=8.0)
        self.far = []

    def correct(self, x_pred, border=None, J=None):
        p = super().correct(x_pred, border, J)
        if p is None or border is None or self.far or x_pred[0] < 0.4:
            return p
        tf = p.tf + 5.0
        self.far.append(tf)
        return ft.FixedTimePoint(tf, np.array([p.z[0], -tf]), p.J, p.m_f - 1.0, 1.0)


def test_an_arclength_step_that_lands_on_a_far_sheet_is_retried_shorter():
    """The walk of the downhill test above, with one corrector landing 5 days of t_f away from
    its predictor: the step counts as failed, it is retried at half the length, and the walk
    reaches the same maximum (u = 1.2) with no point of the far sheet kept."""
    fam = FarSheetFamily()
    s, (left, right), best = search_fold(fam, -0.7)
    assert fam.far and not any(p.tf in fam.far for p in s.kept)
    assert s.folds == 2 and s.downhill == 1
    assert best.z[0] == pytest.approx(1.2, abs=1e-6) and best.tf == pytest.approx(1.2 ** 3 - 1.2, abs=1e-6)


# A snake: t_f = u³ − u as CUBIC, φ with roots at u = −0.9 (first branch, − → + in t_f: a
# maximum), 1.0 (third branch, + → −: a minimum) and 1.3 (third branch: a maximum, the heavier).
SNAKE_PHI = np.polynomial.Polynomial.fromroots([-0.9, 1.0, 1.3])
SNAKE_MASS = -(SNAKE_PHI * np.polynomial.Polynomial([0.0, -1.0, 0.0, 1.0]).deriv()).integ()


@pytest.mark.parametrize("window", [0.5, 1.0])
def test_the_survey_finds_the_other_maxima_of_the_family_within_its_window(window):
    """The E8 full 500 situation on the exact map (the maxima at 321.52 and 322.000 d on one
    family that snakes in t_f): from the maximum at u = −0.9 (t_f 0.171) the survey follows the
    family both ways, through both folds, and certifies the maximum at u = 1.3 (t_f 0.897), not
    the minimum at u = 1.0; a window that does not reach t_f 0.897 finds none."""
    fam = FoldFamily(SNAKE_PHI, SNAKE_MASS, probe_days=0.02, shape=CUBIC, max_points=100)
    fam.opt = dataclasses.replace(fam.opt, max_arc_step=8.0, survey_days=window, survey_max_points=100)
    s = ft.MaximumSearch(fam, tu=ft.DAY, m0_kg=1.0)
    best = s.solve(*fam.start(-0.9))
    maxima = s.survey(best)
    assert maxima[0] is best
    found = sorted(p.z[0] for p in maxima[1:])
    if window < 0.897 - 0.171:
        assert found == [] and min(p.tf for p in s.points) < 0.171 - window    # it left the window
        return
    assert found == pytest.approx([1.3], abs=1e-6) and s.folds == 2
    assert max(maxima, key=lambda p: p.m_f).z[0] == pytest.approx(1.3, abs=1e-6)


# No fold (t_f = u), φ with roots at u = 0 (a maximum), 0.34 (a minimum) and 0.49 (a maximum):
# from 0 the survey's steps double to 8 secants (0.16 d) and one of them, 0.335 → 0.495 d, has
# φ > 0 at both ends with both roots inside, m_f rising across it (the E7 full model at 1 N).
PAIR_PHI = np.polynomial.Polynomial.fromroots([0.0, 0.34, 0.49])
LINE = (lambda u: u, lambda u: 1.0)


def test_a_survey_step_over_a_hidden_pair_of_roots_of_phi_is_retried_shorter():
    """The step whose m_f moves against the sign φ has at both its ends is no step along one
    monotone piece: it is retried shorter, and the maximum at u = 0.49 it passed over is found."""
    fam = FoldFamily(PAIR_PHI, -PAIR_PHI.integ(), probe_days=0.02, shape=LINE, max_points=100)
    fam.opt = dataclasses.replace(fam.opt, max_arc_step=8.0, survey_days=0.6, survey_max_points=100)
    s = ft.MaximumSearch(fam, tu=ft.DAY, m0_kg=1.0)
    best = s.solve(*fam.start(0.0))
    maxima = s.survey(best)
    assert [p.z[0] for p in maxima] == pytest.approx([0.0, 0.49], abs=1e-6)
    kept = sorted(p.tf for p in s.kept)
    assert all(b - a < 0.16 for a, b in zip(kept, kept[1:]) if 0.3 < b < 0.5)   # no step over both roots


# The same with roots at 0, 0.4 and 0.45: the step over the pair has φ > 0 at both ends and m_f
# falls across it as φ says, but far less than φ at its far end says (E7 full model, 87.828 to
# 88.069 d, over the 87.934 d maximum).
NARROW_PAIR_PHI = np.polynomial.Polynomial.fromroots([0.0, 0.4, 0.45])


def test_a_survey_step_whose_ends_fit_no_monotone_mass_is_retried_shorter():
    fam = FoldFamily(NARROW_PAIR_PHI, -NARROW_PAIR_PHI.integ(), probe_days=0.02, shape=LINE, max_points=100)
    fam.opt = dataclasses.replace(fam.opt, max_arc_step=8.0, survey_days=0.6, survey_max_points=100)
    s = ft.MaximumSearch(fam, tu=ft.DAY, m0_kg=1.0)
    best = s.solve(*fam.start(0.0))
    assert [p.z[0] for p in s.survey(best)] == pytest.approx([0.0, 0.45], abs=1e-6)


def test_a_survey_walk_back_at_a_maximum_it_has_found_ends_there():
    """A family periodic in u (t_f = 0.2 sin u, φ = 0.3 + sin 2u, m_f periodic too): each walk
    meets the other maximum once and then comes round to a maximum already found, and ends there
    rather than going round again until its budget is spent (E7 full model: the upward walk
    turned back onto itself at 88.562 d and found 87.934 and 87.565 d again)."""
    phi = lambda u: 0.3 + np.sin(2.0 * u)
    mass = lambda u: -0.2 * (0.3 * np.sin(u) - (2.0 / 3.0) * np.cos(u) ** 3)
    fam = FoldFamily(phi, mass, probe_days=0.02, shape=(lambda u: 0.2 * np.sin(u), lambda u: 0.2 * np.cos(u)),
                     max_points=100)
    fam.opt = dataclasses.replace(fam.opt, max_arc_step=4.0, survey_days=1.0, survey_max_points=60)
    s = ft.MaximumSearch(fam, tu=ft.DAY, m0_kg=1.0)
    best = s.solve(*fam.start(-0.5 * np.arcsin(0.3)))
    maxima = s.survey(best)
    assert len(maxima) == 2 and maxima[1].tf == pytest.approx(0.2 * np.sin(np.pi / 2 + 0.5 * np.arcsin(0.3)), abs=1e-6)
    assert fam.solves < 60


def test_the_march_gives_up_after_max_points():
    fam = ModelFamily(lambda t: t - 100.0, lambda t: -0.5 * (t - 100.0) ** 2, probe_days=0.5)
    fam.opt = dataclasses.replace(fam.opt, max_points=6)
    s, found, _ = search(fam, 0.0)
    assert isinstance(found, str) and "no sign change" in found and len(s.points) == 6


def test_brent_returns_a_crossing_from_minus_to_plus_inside_a_wiggly_bracket():
    """Three roots in the bracket (max, min, max), m_f flat: every root returned is a − → +
    crossing, never the minimum at 0.5."""
    phi = lambda t: (t - 0.2) * (t - 0.5) * (t - 0.8)
    fam = ModelFamily(phi, lambda t: 0.0)
    s = ft.MaximumSearch(fam, tu=ft.DAY, m0_kg=1.0)
    left, right = s.solve(0.0, np.zeros(2)), s.solve(1.0, np.zeros(2))
    roots = s.root(left, right)
    assert roots and all(min(abs(p.tf - 0.2), abs(p.tf - 0.8)) < 1e-8 for p in roots)
    assert all(phi(p.tf - 1e-3) < 0 < phi(p.tf + 1e-3) for p in roots)


# φ with roots at 0.2153 (a maximum), 0.2718 (a minimum) and 0.7404 (a maximum, the heavier):
# Brent on [0, 1] ends at the lighter maximum, 0.2153 (E7 full model: the survey's bracket
# 87.54–88.10 d held two maxima and the minimum between them, "sixty-seventh session").
TWO_MAXIMA_PHI = np.polynomial.Polynomial.fromroots([0.2153, 0.2718, 0.7404])


def test_a_bracket_with_two_maxima_gives_both_the_heavier_first():
    """Brent's points right of its root (φ > 0 at both ends of that stretch) fit no monotone
    m_f: its midpoint is solved, the other crossing appears and is solved too."""
    mass = -TWO_MAXIMA_PHI.integ()
    fam = ModelFamily(TWO_MAXIMA_PHI, mass)
    s = ft.MaximumSearch(fam, tu=ft.DAY, m0_kg=1.0)
    left, right = s.solve(0.0, np.zeros(2)), s.solve(1.0, np.zeros(2))
    first = ft.brentq(TWO_MAXIMA_PHI, 0.0, 1.0, xtol=s.opt.tof_tol_days)
    assert first == pytest.approx(0.2153, abs=1e-6)                 # Brent alone: the lighter one
    assert [p.tf for p in s.root(left, right)] == pytest.approx([0.7404, 0.2153], abs=1e-6)
    assert mass(0.7404) > mass(0.2153)


def test_a_stretch_of_one_sign_of_phi_is_told_from_one_that_hides_two_roots():
    """hidden_slope: zero for a monotone m_f (φ > 0 from 0 to 1) and where φ changes sign;
    positive where φ > 0 at both ends but negative inside (0.3 to 0.6)."""
    point = lambda P, t: ft.FixedTimePoint(t, np.zeros(2), np.eye(2), float(-P.integ()(t)), float(P(t)))
    monotone = np.polynomial.Polynomial([1.0, 0.0, 1.0])
    pair = np.polynomial.Polynomial.fromroots([0.3, 0.6])
    assert ft.hidden_slope(point(monotone, 0.0), point(monotone, 1.0)) == 0.0
    assert ft.hidden_slope(point(pair, 0.0), point(pair, 0.5)) == 0.0
    assert ft.hidden_slope(point(pair, 0.0), point(pair, 1.0)) > 0.0


@pytest.fixture(scope="module")
def perturbed_e1(e1_g22_era):
    """E1 OT 15 N (2 revolutions) with EGM96 2×2 and the Earth rotation angle switched on
    (conftest), and the end game from it with probes 0.01 d apart."""
    sol = e1_g22_era[0]
    opt = ft.MaximumOptions(probe_days=0.01, verbose=False)
    return sol, opt, ft.maximise_final_mass(sol, opt)


def test_the_perturbed_extremal_is_certified_a_maximum_and_kept(perturbed_e1):
    sol, opt, (out, rec) = perturbed_e1
    assert rec["status"] == "maximum" and rec["certified"]
    (t_lo, _, phi_lo), (t_hi, _, phi_hi) = rec["points"][0], rec["points"][-1]
    assert phi_lo < 0 < phi_hi and t_hi - t_lo == pytest.approx(2 * opt.probe_days)
    assert abs(rec["tof_days"] - rec["t0_days"]) < 1e-3 and rec["free_time_residual"] < 1e-8
    np.testing.assert_allclose(out.z, sol.z, rtol=1e-6, atol=1e-9)


def test_the_survey_of_a_family_with_one_maximum_keeps_it_and_records_it(perturbed_e1):
    """E1 2×2 (m_f(t_f) smooth, one maximum): the survey walks ±0.03 d from the certified maximum
    and finds no other; the record lists the one maximum, and the solution is the same."""
    sol, opt, (out, rec) = perturbed_e1
    out_s, rec_s = ft.maximise_final_mass(sol, dataclasses.replace(opt, survey_days=0.03, survey_max_points=12))
    assert rec_s["certified"] and rec_s["survey"]["window_days"] == 0.03
    assert rec_s["survey"]["maxima"] == [[rec_s["tof_days"], rec_s["m_f_kg"], rec_s["phi"]]]
    assert rec_s["tof_days"] == rec["tof_days"] and rec_s["survey"]["first_tof_days"] == rec["tof_days"]
    points = [p[0] for p in rec_s["points"]]
    assert min(points) < rec["tof_days"] - 0.03 and max(points) > rec["tof_days"] + 0.03   # the window walked
    np.testing.assert_array_equal(out_s.z, out.z)


def test_the_envelope_relation_holds_on_the_fixed_time_family(perturbed_e1):
    """dm_f/dt_f = −m₀ φ: the mass change from the maximum to each probe equals the trapezoid
    integral of −m₀ φ (φ nearly linear over 0.01 d)."""
    sol, opt, (_, rec) = perturbed_e1
    tu_days = sol.transfer.tu / ft.DAY
    t0, m0_f, phi0 = next(p for p in rec["points"] if p[0] == rec["t0_days"])
    for t, m, phi in (rec["points"][0], rec["points"][-1]):
        predicted = -sol.transfer.m0 * 0.5 * (phi0 + phi) * (t - t0) / tu_days
        assert m - m0_f == pytest.approx(predicted, rel=0.05), (t, m - m0_f, predicted)
    assert m0_f > max(rec["points"][0][1], rec["points"][-1][1])


def test_from_a_fixed_time_point_off_the_maximum_the_march_returns_to_it(perturbed_e1):
    """A start 0.035 d above the maximum (the fixed-time extremal there, φ > 0): the march goes
    down and lands on the free-time extremal that Newton found."""
    sol, opt, (_, rec) = perturbed_e1
    family = ft.FixedTimeFamily(sol.shooting, sol.prm, opt)
    tf = (rec["t0_days"] + 0.035) * ft.DAY / sol.transfer.tu
    off = family.point(tf, ft.extrapolate([family.point(family.end_time(sol.z), sol.z)], tf, family.e_t))
    assert off is not None and off.phi > 0
    out, rec_off = ft.maximise_final_mass(dataclasses.replace(sol, z=off.z), opt)
    assert rec_off["status"] == "maximum" and rec_off["m_f_gain_kg"] > 0
    assert rec_off["tof_days"] == pytest.approx(rec["t0_days"], abs=2e-4)
    np.testing.assert_allclose(out.z, sol.z, rtol=1e-4, atol=1e-7)


def test_an_interrupted_end_game_resumes_from_the_saved_free_time_solution(perturbed_e1, tmp_path):
    """perturbed_solve saves the Newton solution before the end game (the continuation checkpoints
    are gone by then); a rerun reads it back with its extra and wall time, and a file that does
    not read back is no start."""
    from spaceopt.studies import perturbed as P
    sol = perturbed_e1[0]
    path = tmp_path / "free_time_start.json"
    assert P.end_game_start(path) is None
    P.save(sol, path, {"case": "e1 g22"}, 123.0, {"continued_from": "chain"}, samples_per_rev=20)
    back, extra, wall = P.end_game_start(path)
    np.testing.assert_array_equal(back.z, sol.z)
    assert back.transfer.perturbed and extra["continued_from"] == "chain" and wall == 123.0
    from spaceopt import artifacts
    start = extra["free_time_start_provenance"]      # the code and config the start was computed with
    assert start["config_hash"] == artifacts.config_hash({"case": "e1 g22"}) and start["wall_time_s"] == 123.0
    path.with_suffix(".npz").write_bytes(b"truncated")
    assert P.end_game_start(path) is None


def test_a_model_step_whose_polish_fails_hands_its_end_point_to_the_end_game(perturbed_e1):
    """A warm start whose path reaches τ = 1 but whose final polish fails (here: a tolerance no
    iterate can meet) leaves its point of least |F| on the exception as the new problem's
    unconverged solution (E8 450 rev, full model: no free-time root near the path's end);
    ``P.end_point_of`` accepts it for the problem asked, and the end game from it certifies the
    maximum that a converged solve gives (checked against the J2 extremal solved directly)."""
    from spaceopt.errors import ConvergenceError
    from spaceopt.studies import perturbed as P

    sol, opt, _ = perturbed_e1
    tr_j2 = dataclasses.replace(sol.transfer, perturbations={"geopotential": "j2", "earth_angle": "era"})
    j2 = P.warm_start(sol, tr_j2, "e1 j2", options=QUIET, model_path="arclength")
    with pytest.raises(ConvergenceError, match="final Newton polish") as info:
        P.warm_start(sol, tr_j2, "e1 j2 failing", model_path="arclength",
                     options=ContinuationOptions(verbose=False, tol_final=1e-30))
    diagnosis = info.value.diagnosis
    end = P.end_point_of(info.value, tr_j2)
    assert end is not None and end.transfer is tr_j2 and diagnosis["residual_best"] < 1e-8
    np.testing.assert_array_equal(end.z, diagnosis["z_best"])
    assert "z" not in end.stats and end.stats["reason"] == diagnosis["reason"]    # no stale unknowns
    assert P.end_point_of(info.value, sol.transfer) is None          # not the problem asked
    out, rec = ft.maximise_final_mass(end, opt)
    assert rec["certified"] and rec["free_time_residual"] < 1e-8
    np.testing.assert_allclose(out.z, j2.z, rtol=1e-5, atol=1e-8)


class LiftFamily(FoldFamily):
    """A family whose folds come from the smoothing: t_f = u³ − a(ε) u with a = 1 at ε_f = 1e-5
    (folds at u = ∓1/√3, as CUBIC) falling log-linearly to a = −0.5 at ε = 1e-3 (no fold), and
    φ = u − 1.2 at every ε (m_f its envelope integral at the family's ε)."""

    EPS_F, EPS_LIFT = 1e-5, 1e-3

    def __init__(self, fails_lifted=(np.inf, np.inf), **kw):
        super().__init__(CUBIC_PHI, self.mass_at, shape=(lambda u: u ** 3 - self.a() * u, lambda u: 3.0 * u * u - self.a()), **kw)
        self.eps = self.eps_f = self.EPS_F
        self.fails_lifted = fails_lifted        # t_f range where Newton fails at the lifted ε

    def point(self, tf, z, J=None):
        lo, hi = self.fails_lifted
        return None if self.eps == self.EPS_LIFT and lo < tf < hi else super().point(tf, z, J)

    def a(self):
        return 1.0 - 1.5 * np.log(self.eps / self.EPS_F) / np.log(self.EPS_LIFT / self.EPS_F)

    def set_eps(self, eps):
        self.eps = eps

    def mass_at(self, u):
        a = self.a()
        return -(0.75 * u ** 4 - 1.2 * u ** 3 - 0.5 * a * u * u + 1.2 * a * u)


@pytest.mark.parametrize("lift_eps", [0.0, LiftFamily.EPS_LIFT])
def test_where_the_family_folds_at_eps_f_the_search_goes_across_at_a_larger_eps(lift_eps):
    """The E8 full-model 500 situation: from u₀ = −1.5 the branch rises in m_f to a fold with
    φ ≠ 0, and steps in t_f cannot reach the maximum at u = 1.2 beyond the next fold. At ε = 1e-3
    the family has no fold: the lift moves the origin there at its t_f, the lifted search brackets
    that ε's maximum, the descent back to ε_f at the bracket's t_f lands on the outer branch
    u > 1/√3, and the search at ε_f from there finds the maximum at u = 1.2 (t_f = 0.528)."""
    fam = LiftFamily(probe_days=0.3, max_points=40, fails_lifted=(0.1, 0.3))
    fam.opt = dataclasses.replace(fam.opt, lift_eps=lift_eps, lift_probe_days=0.3, lift_max_points=40)
    t0, z0 = fam.start(-1.5)
    s = ft.MaximumSearch(fam, tu=ft.DAY, m0_kg=1.0)
    origin = s.solve(t0, z0)
    found = s.bracket(origin)
    assert isinstance(found, str) and "folds" in found and s.folds == 1
    if lift_eps == 0.0:
        return
    before = len(s.points)
    left, right = s.across_branches(origin, found)
    assert fam.eps == fam.eps_f and not s.at_lift
    assert s.lifted and s.lift_bracket[0] < 1.2 ** 3 + 0.5 * 1.2 < s.lift_bracket[1]   # the lifted maximum
    best, = s.root(left, right)
    assert best.z[0] == pytest.approx(1.2, abs=1e-6) and best.tf == pytest.approx(1.2 ** 3 - 1.2, abs=1e-6)
    assert all(p.z[0] > 1.0 / np.sqrt(3.0) for p in s.points[before:])      # landed beyond the folds
    lifted = sorted(p.tf for p in s.lifted)
    assert not any(0.1 < t < 0.3 for t in lifted)         # a lifted step halved past where Newton fails,
    assert lifted[-1] - lifted[-2] == pytest.approx(0.3)  # then grown back to δ


def test_a_lift_that_finds_nothing_leaves_the_family_at_eps_f():
    """The lifted search runs out of solves (lift_max_points 3) next to the origin: the descent
    where its |φ| is least lands on the origin's branch again, the reason names both searches,
    and the family, δ and the search are back at ε_f (the record's free-time residual is
    evaluated there)."""
    fam = LiftFamily(probe_days=0.3, max_points=40)
    fam.opt = dataclasses.replace(fam.opt, lift_eps=LiftFamily.EPS_LIFT, lift_probe_days=0.3, lift_max_points=3)
    t0, z0 = fam.start(-1.5)
    s = ft.MaximumSearch(fam, tu=ft.DAY, m0_kg=1.0)
    origin = s.solve(t0, z0)
    delta = s.delta
    found = s.across_branches(origin, s.bracket(origin))
    assert isinstance(found, str) and "folds" in found and "after the lift" in found
    assert "no sign change" in s.lift_failed and s.lift_bracket is None
    assert fam.eps == fam.eps_f and not s.at_lift and s.delta == delta and s.lifted


def test_a_lift_that_brackets_nothing_still_descends_where_phi_came_closest_to_zero():
    """E8 full 500 (scratch): the lifted march ends without a sign change of φ, but the descent
    from its point of least |φ| lands beyond the ε_f folds, and the search at ε_f from there finds
    the maximum at u = 1.2 (a maximum certified at ε_f like any other)."""
    fam = LiftFamily(probe_days=0.3, max_points=40)
    fam.opt = dataclasses.replace(fam.opt, lift_eps=LiftFamily.EPS_LIFT, lift_probe_days=0.3, lift_max_points=12)
    t0, z0 = fam.start(-1.5)
    s = ft.MaximumSearch(fam, tu=ft.DAY, m0_kg=1.0)
    origin = s.solve(t0, z0)
    left, right = s.across_branches(origin, s.bracket(origin))
    assert s.lift_failed and s.lift_bracket is None and max(p.phi for p in s.lifted) < 0.0
    assert [p.z[0] for p in s.root(left, right)] == pytest.approx([1.2], abs=1e-6) and fam.eps == fam.eps_f


class JumpFamily(ModelFamily):
    """φ = t_f − 2 with, for t_f in (1.7, 1.9) reached by a step longer than 0.1 d, Newton's
    point on another branch: 0.5 lighter with φ still < 0 (from a start too far away)."""

    def __init__(self):
        super().__init__(lambda t: t - 2.0, lambda t: -0.5 * (t - 2.0) ** 2, probe_days=0.25)
        self.last, self.jumped = 1.0, []

    def point(self, tf, z, J=None):
        p = super().point(tf, z, J)
        if 1.7 < tf < 1.9 and abs(tf - self.last) > 0.1:
            self.jumped.append(tf)
            return ft.FixedTimePoint(tf, p.z, p.J, p.m_f - 0.5, p.phi)
        self.last = tf
        return p


def test_a_step_that_lands_on_a_lighter_branch_is_retried_shorter():
    """E8 full 500 at ε 1e-3 (this session's DAG run): a march step converges on another branch,
    m_f lower while φ < 0, against dm_f/dt_f = −φ. The march rejects the point (branch_jump),
    retries the step shorter, passes the stretch and brackets the maximum at t_f = 2 with no
    point of the other branch kept."""
    fam = JumpFamily()
    s, (left, right), best = search(fam, 1.0)
    assert fam.jumped and not any(p.tf in fam.jumped and p.m_f < -0.4 for p in s.points)
    assert s.arc_points == 0 and best.tf == pytest.approx(2.0, abs=1e-6)
