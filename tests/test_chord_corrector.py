"""The chord and Broyden correctors of the continuation followers (``ContinuationOptions.corrector``):
the chord corrector's later steps reuse the Jacobian of its first evaluation and evaluate f
alone, a fresh Jacobian where a chord step reduces |F| without halving it; Broyden's carries the
Jacobian from step to step with rank-one updates. Same paths, same end points as the Newton
corrector, fewer Jacobians."""
import numpy as np
import pytest

from spaceopt.indirect.continuation import (ArclengthContinuation, ArclengthOptions, Continuation,
                                            ContinuationOptions)


class Counted:
    """f(z, τ) = (z₀³ + z₁ − 2τ, z₁³ + z₁ − z₀ − τ) with its derivatives, evaluations counted:
    ``evaluate`` (f, J, f_τ; a 'Jacobian') and ``residual`` (f alone)."""

    def __init__(self):
        self.jacobians = self.residuals = 0

    @staticmethod
    def f(z, tau):
        return np.array([z[0] ** 3 + z[1] - 2 * tau, z[1] ** 3 + z[1] - z[0] - tau])

    def evaluate(self, z, tau):
        self.jacobians += 1
        J = np.array([[3 * z[0] ** 2, 1.0], [-1.0, 3 * z[1] ** 2 + 1]])
        return self.f(z, tau), J, np.array([-2.0, -1.0]), 0, True

    def residual(self, z, tau):
        self.residuals += 1
        return self.f(z, tau), True


def _cubic(jac_at: list):
    """The corrector's callbacks for f = z + z³: (residual(x, held), newton_step(x, F, ev));
    ``residual`` without ``held`` evaluates J and records where in ``jac_at``."""
    def residual(x, held=None):
        F = np.atleast_1d(x + x ** 3)
        if held is not None:
            return F, held
        jac_at.append(float(x[0]))
        return F, (np.array([[1 + 3 * x[0] ** 2]]),)

    def newton_step(x, F, ev):
        return x - np.linalg.solve(ev[0], F)

    return residual, newton_step


@pytest.mark.parametrize("follower, options", [(Continuation, ContinuationOptions),
                                               (ArclengthContinuation, ArclengthOptions)])
def test_chord_and_broyden_correctors_follow_the_newton_path_with_fewer_jacobians(follower, options):
    ends = {}
    for mode in ("newton", "chord", "broyden"):
        fz = Counted()
        cont = follower(fz.evaluate, options(verbose=False, corrector=mode, h_max=0.5), residual=fz.residual,
                        path_residual=fz.residual)
        z, _ = cont.run(np.array([0.0, 0.0]))
        assert np.abs(Counted.f(z, 1.0)).max() < 1e-10
        ends[mode] = (z, fz.jacobians, cont.stats)
    (z_n, jac_n, st_n), (z_c, jac_c, st_c), (z_b, jac_b, st_b) = ends["newton"], ends["chord"], ends["broyden"]
    np.testing.assert_allclose(z_c, z_n, atol=1e-10)
    np.testing.assert_allclose(z_b, z_n, atol=1e-10)
    assert st_n.residuals == 0 and st_c.residuals > 0      # chord steps were taken
    assert st_c.jacobians == jac_c and jac_c < jac_n
    assert st_b.jacobians == jac_b and jac_b < jac_c       # the Jacobian carried across steps


def test_broyden_retakes_a_step_that_its_carried_jacobian_spoils():
    """f = z + z³ from z = 1 with a carried Jacobian of the wrong sign (−1): the step goes to
    z = 3 (|F| 2 → 30); the corrector retakes it with J evaluated at z = 1 (4), once, then goes
    on by Broyden steps (f alone, rank-one updates) to the root."""
    jac_at = []
    residual, newton_step = _cubic(jac_at)

    def update(ev, dx, dF):
        return (ev[0] + np.outer(dF - ev[0] @ dx, dx) / np.dot(dx, dx),)

    cont = Continuation(lambda z, t: None, ContinuationOptions(verbose=False, corrector="broyden", tol_step=1e-6,
                                                               max_chord=12),
                        path_residual=lambda z, t: None)
    accepted, x, F, ev, nF, evals = cont._correct(np.array([1.0]), residual, newton_step,
                                                  carried=(np.array([[-1.0]]),), update=update)
    assert accepted and abs(x[0]) < 1e-6
    assert jac_at == [1.0]                      # the one fresh Jacobian: at the spoilt step's start
    assert evals > 3                            # the rest were evaluations of f alone


def test_a_slow_chord_step_takes_a_fresh_jacobian_and_goes_on_by_newton():
    """f = z + z³ from z = 1 with J held there (4): chord steps to 0.5 (|F| 2 → 0.625, halved),
    then 0.344 (|F| 0.385, not halved): the corrector evaluates J at 0.344 and goes on with chord
    steps from it (each now at least halving |F|) instead of rejecting the step."""
    jac_at = []
    residual, newton_step = _cubic(jac_at)

    cont = Continuation(lambda z, t: None, ContinuationOptions(verbose=False, corrector="chord", tol_step=1e-4,
                                                               max_chord=10),
                        path_residual=lambda z, t: None)
    accepted, x, F, ev, nF, evals = cont._correct(np.array([1.0]), residual, newton_step)
    assert accepted and abs(x[0]) < 1e-4
    assert jac_at[0] == 1.0 and jac_at[1] == pytest.approx(0.34375)     # the refresh at the slow step
    assert len(jac_at) < evals                                          # the other steps were chords


def test_chord_corrector_options_are_checked():
    fz = Counted()
    with pytest.raises(ValueError, match="corrector 'secant'"):
        Continuation(fz.evaluate, ContinuationOptions(corrector="secant"))
    with pytest.raises(ValueError, match="needs path_residual"):
        Continuation(fz.evaluate, ContinuationOptions(corrector="chord"), residual=fz.residual)


def test_the_polish_steps_across_an_edge_of_the_map_once_then_stays_on_its_side():
    """f(x) = 10(x − 0.9) − 1e-6 below the edge x = 0.9 (its root lies beyond the edge) and
    x − 0.95 above it. Newton from 0.8999 steps across the edge, |F| 1e-3 → 0.05: the plain
    polish stops there (|F| 1e-3, a failure); with ``polish_crossings`` it goes on to the root 0.95."""
    from spaceopt.errors import ConvergenceError

    def f(x):
        return np.atleast_1d(10 * (x[0] - 0.9) - 1e-6 if x[0] < 0.9 else x[0] - 0.95)

    def ev(x, tau):
        return f(x), np.array([[10.0 if x[0] < 0.9 else 1.0]]), np.zeros(1), 0, True

    def polish(**kw):
        # a polish distinct from the path's map: f itself at τ = 1, not the Newton homotopy's f − b
        cont = Continuation(ev, ContinuationOptions(verbose=False, **kw), polish=lambda x, t: ev(x, t),
                            residual=lambda x, t: (f(x), True))
        return cont.run(np.array([0.8999]), tau0=1.0)[0]

    with pytest.raises(ConvergenceError, match="polish"):
        polish()
    assert polish(polish_crossings=1)[0] == pytest.approx(0.95, abs=1e-12)
