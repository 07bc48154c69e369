"""The free-time end game: a local maximum of the final mass along the fixed-time family.

A perturbed free-time OT extremal (time free: p_t(K_f) = 0, spec 01-methods §2.1) is a
stationary point of the final mass over the **fixed-time** extremals through it. At a fixed
t_f the shooting map keeps its unknowns z and replaces the row p_t(K_f) = 0 by t(K_f) = t_f
(1.1.11); with φ(t_f) = p_t(K_f) of that extremal the envelope theorem gives

    dm_f/dt_f = −φ(t_f)          (m in units of m₀, t in time units),

checked by finite differences to 1–2 % on E5 (docs/perturbed-e6-e7-e8.md, "twenty-first
session"). The roots of φ are the free-time extremals, and a root where φ turns from − to + as
t_f grows is a local maximum of m_f in t_f. Newton on the free-time map finds *a* root, and
under the lunisolar perturbations φ wiggles (E8 full model: amplitude ~5e-7 on a 0.1–0.3 d
scale, against a slope of 2.35e-7 per 0.1 d unperturbed), so that its polish, which accepts
|F| ≤ 1e-7, also lands on degenerate points: E8 250 revolutions from scratch, 177.4674 d, where
φ rises to −4e-8 and falls again (an inflection of m_f; the maximum is 1.5 g heavier at
177.805 d). The fixed-time family can also fold in t_f: E8 500, 321.1281 d, is a maximum of its
own branch 0.005 d below a fold, beyond which another branch has a maximum 0.09 g heavier at
321.028 d (docs, "twenty-third session"); which one the search reaches depends on the branch
its probes land on.

:func:`maximise_final_mass` takes a converged perturbed free-time solution and

1. solves the fixed-time extremal at its own t_f = t(K_f) (Newton from its z);
2. probes t_f ± δ (``probe_days``; δ/2 … δ/8 where Newton fails at δ); a local maximum lies
   between them where φ(t_f − δ) < 0 < φ(t_f + δ);
3. otherwise marches uphill in m_f (towards −sign φ, from the probe with the larger m_f) by
   steps of the probe's distance, each start extrapolated through the last solutions in t_f,
   the step halved where Newton fails (to δ/8), until φ turns from − to +; where a step fails
   even at δ/8 (or a probe fails on one side only, E8 500 rev), the family is followed on by
   pseudo-arclength in (z, t_f), round a fold in t_f onto the branch beyond it, uphill in m_f
   (dm_f/ds = −m₀ φ dt_f/ds along the family), until φ turns from − to + on one branch or the
   family folds with φ ≠ 0 (a maximum of m_f along it that is no free-time extremal), or, with
   ``downhill_folds``, on past such folds, downhill along the family until m_f rises again,
   to a maximum on a branch beyond (which can be lighter than the start: the record's gain);
4. where steps 2–3 bracket no maximum, looks again on the family at a larger smoothing ε
   (``lift_eps``, :meth:`MaximumSearch.across_branches`): the origin moved there at its t_f,
   steps 2–3 at that ε, its bracket's point moved back to ε_f at its t_f, and steps 2–3 at ε_f
   from where it lands (E8 full 500: past a fold at ε_f with φ ≠ 0 to the 321.028 d maximum,
   docs/perturbed-e6-e7-e8.md, "thirty-second session");
5. finds the root in that bracket by Brent's method (``scipy.optimize.brentq``, to
   ``tof_tol_days``; each value of φ a fixed-time Newton solve started from the bracket's
   solutions interpolated in t_f). Brent keeps a sign change between the ends of its bracket,
   each new point replacing the end of its own sign, so the negative end stays on the left and
   the root it returns is a crossing of φ from − to +: a local maximum of m_f. Where the
   solution itself lies in a bracket of the probes, Brent runs on the half of it that the
   solution's φ bounds: one value of φ alone does not tell a maximum from a minimum. A bracket
   can hold two maxima and the minimum between them; the bracket's solved points are read
   again, other crossings they show solved too, stretches whose m_f and φ fit no monotone m_f
   split (:func:`hidden_slope`), and the heaviest maximum found returned;

6. with ``survey_days``, follows the family on from that maximum both ways by arclength
   within a window of t_f, through its folds, certifies every other local maximum met there
   (:meth:`MaximumSearch.survey`), and returns the heaviest: on the exact map E8 full 500's
   family snakes in t_f with folds 0.1–0.2 d apart, and maxima that the route reaches by
   round-off lie on it (docs/perturbed-e6-e7-e8.md, "fortieth session").

The fixed-time extremal at that root satisfies every free-time row but p_t(K_f), which is φ
there. Where no bracket is found within ``max_points`` fixed-time solves, the solution is
returned unchanged and the record says so. Each fixed-time solve is Newton's method with chord
steps, the Jacobian of the neighbouring solved point first (:meth:`FixedTimeFamily.point`;
E8 250 from the inflection: 7 Jacobians and 45 residuals, about 13.5 Jacobians' worth,
against 30 Jacobians; wall ratio 0.50 and 0.75 in two side-by-side runs on a shared machine,
``benchmarks/free_time.py``). The Newton iterations and the march are written by hand:
each value of the one-dimensional function φ is a Newton solve warm-started from its
neighbours, a state that the bracketing solvers of scipy and optimistix do not carry between
their evaluations. The pseudo-arclength steps (:meth:`MaximumSearch.follow_arc`) are not
:class:`~.continuation.ArclengthContinuation`'s: that one follows a Newton homotopy in τ from 0
to 1 and polishes at τ = 1; this one follows F(z, t_f) = 0 with no end in t_f, stops on the
sign of −φ dt_f/ds, and shares the fixed-time corrector above (one bordered Newton with chord
steps for both).
"""
from __future__ import annotations

import dataclasses
import sys
import time
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np
from scipy.optimize import brentq

from ..constants import DAY
from . import hamiltonians as hm
from .shooting import final_state, residual, shoot
from .transfer import datum


@dataclass
class MaximumOptions:
    probe_days: float = 0.05        # δ: the probes at t_f ± δ and the march's step
    max_march_days: float = 0.0     # > δ: the march's step doubled after each solved point up to this (at ε_f;
    # thrust_family.hop, whose start may lie days from the crossing); 0: at most δ
    tof_tol_days: float = 1e-4      # the width at which Brent's bracket ends
    max_points: int = 16            # fixed-time solves of the probes and the march at most
    newton_tol: float = 3e-8        # |f|₂ of a fixed-time point, the time row excepted (E8: the
    # DAG's extremals end at 1.6e-8 … 4e-8; Newton jitters at 2e-9 over 250 revolutions and at
    # 1e-8 … 4e-8 over 450, rtol 1e-11)
    time_rtol: float = 1e-8         # |t(K_f) − t_f| relative to t_f (t(K_f) carries the integration error)
    max_newton: int = 12            # Jacobians per fixed-time point (E8 500 near a fold: 9)
    chord_steps: int = 3            # steps per Jacobian after its Newton step (FixedTimeFamily.point); 0: Newton
    downhill_folds: int = 0         # folds with φ ≠ 0 the arclength walk may pass, going on downhill in
    # m_f to look for a maximum on the branches beyond (0: it stops at the first, MaximumSearch.follow_arc)
    max_arc_step: float = 1.0       # the walk's longest step, in lengths of the secant it starts from
    lift_eps: float = 1e-3          # where the search at ε_f brackets no maximum: the smoothing ε at which
    # it looks again, across the branches of the ε_f family (MaximumSearch.across_branches); 0: off
    lift_steps: int = 4             # log-uniform steps in ε between ε_f and lift_eps, each way
    lift_probe_days: float = 0.1    # δ of the search at lift_eps (E8 full 500: its maximum 1.1 d from the origin)
    lift_max_points: int = 32       # fixed-time solves of the search at lift_eps at most
    survey_days: float = 0.0        # after a certified maximum: the other local maxima on its family within
    # this many days of it, the heaviest returned (MaximumSearch.survey; 0: off)
    survey_max_points: int = 40     # fixed-time solves of the survey each way at most
    jump_tol: float = 1e-9          # a step whose m_f moves against φ's sign by more (relative) left another branch
    hidden_tol: float = 2e-8        # MaximumSearch.hides_roots: the least m_f change (relative) it reads as a
    # pair of roots; m_f of a fixed-time point is known to a few mg in E7 (the 87.565 d extremal solved twice:
    # 853.338530 and 853.338527 kg, 3.5e-9), and at 1e-9 the test split stretches of 0.005 d around it
    bracket_splits: int = 8         # midpoints solved inside a bracket where such a pair of its points hides roots
    verbose: bool = True
    label: str = ""


@dataclass
class FixedTimePoint:
    """A fixed-time extremal: t_f (time units), its unknowns z and Jacobian J, the final mass
    m_f (units of m₀) and φ = p_t(K_f)."""
    tf: float
    z: np.ndarray
    J: np.ndarray
    m_f: float
    phi: float

    @property
    def x(self) -> np.ndarray:
        """The point in (z, t_f), the unknowns of :meth:`FixedTimeFamily.correct`."""
        return np.append(self.z, self.tf)


class FixedTimeFamily:
    """The fixed-time problems of one perturbed free-time problem (shooting ``sh``, data ``prm``).

    Its points solve F(z, t_f) = 0, the fixed-time shooting map at t_f, whose time row is
    t(K_f) − t_f: ∂F/∂t_f = −e_t. :meth:`correct` solves F together with one linear border row,
    t_f = t_pred (:meth:`point`) or a pseudo-arclength row (:meth:`MaximumSearch.follow_arc`)."""

    def __init__(self, sh, prm, opt: MaximumOptions):
        if hm.TIME not in sh.free_costates or sh.fixed_time:
            raise ValueError("the fixed-time family needs a free-time problem with p_t among its unknowns")
        self.sh_free, self.sh = sh, dataclasses.replace(sh, fixed_time=True)
        self.prm, self.opt = prm, opt
        self.eps_f = self.eps = float(prm["eps_final"])
        self.jacobians = self.residuals = self.solves = 0
        self.e_t = np.zeros(sh.size)
        self.e_t[sh.residual_names().index("p_t(K_f)")] = 1.0     # the row t(K_f) − t_f

    def set_eps(self, eps: float):
        """The family of the same problem at smoothing ε (the OT map reads it from prm['eps_final'])."""
        self.eps, self.prm = eps, {**self.prm, "eps_final": datum(eps)}

    def end_time(self, z) -> float:
        """t(K_f) of the unknowns z (time units)."""
        yf, ok = final_state(self.sh_free, jnp.asarray(z), 1.0, self.prm)
        if not ok:
            raise ValueError("the propagation of the free-time solution failed")
        return float(yf[hm.TIME])

    def evaluate(self, z, tf, jacobian: bool):
        """F(z, t_f) and, where ``jacobian``, ∂F/∂z: (f, J or None, ok)."""
        prm = {**self.prm, "tf": datum(tf)}
        if jacobian:
            f, J, _, _, ok = shoot(self.sh, jnp.asarray(z), 1.0, prm)
            self.jacobians += 1
            return np.asarray(f), np.asarray(J), ok
        f, ok = residual(self.sh, jnp.asarray(z), 1.0, prm)
        self.residuals += 1
        return np.asarray(f), None, ok

    def point(self, tf: float, z, J=None) -> FixedTimePoint | None:
        """The fixed-time extremal at ``tf`` from ``z`` (:meth:`correct` with the row t_f = tf)."""
        return self.correct(np.append(np.asarray(z, float), tf), None, J)

    def correct(self, x_pred, border=None, J=None) -> FixedTimePoint | None:
        """The point x = (z, t_f) of the family with F(z, t_f) = 0 and border·(x − x_pred) = 0
        (``border`` None: t_f = t_pred), from x_pred; None where it fails (``max_newton``
        Jacobians, or a Newton step that grows |f| tenfold).

        Newton's method on the bordered system [[∂F/∂z, −e_t], [border]] with chord steps
        (Shamanskii): after each Newton step the same Jacobian serves up to ``chord_steps`` chord
        steps, each costing a residual without sensitivities (a sixth of a Jacobian at E8 250
        rev). A chord step that does not halve |f| ends them: the next Jacobian is evaluated at
        its point where it lowered |f|, else at the point it started from; after a Newton step
        that does not halve |f|, at its point (Newton's iteration). Every Jacobian is thus
        evaluated at a new point (going back to the best point instead, E8 500 cycled between
        the same two Newton steps). ``J``: a neighbour's Jacobian, whose chord steps start the
        solve. With border e_{t_f} the step is Newton's on F(·, t_pred) alone."""
        opt = self.opt
        self.solves += 1
        x_pred = np.asarray(x_pred, float)
        b = np.eye(x_pred.size)[-1] if border is None else np.asarray(border, float)
        x, rows, J = x_pred.copy(), self.e_t == 0, J if opt.chord_steps > 0 else None
        jacobians, uses, fresh, newton_step = 0, 0, False, False
        x_from, n_from = x, np.inf                  # where the last step began, and its |f|
        while True:
            if J is None:
                if jacobians >= opt.max_newton:
                    return None
                f, J, ok = self.evaluate(x[:-1], x[-1], True)
                jacobians, uses, fresh = jacobians + 1, 0, True
            else:
                f, _, ok = self.evaluate(x[:-1], x[-1], False)
            nf = float(np.linalg.norm(f[rows])) if ok and np.all(np.isfinite(f)) else np.inf
            if nf <= opt.newton_tol and abs(f[~rows][0]) <= opt.time_rtol * abs(x[-1]):
                return self._point(x[-1], x[:-1], J)
            if newton_step and not nf <= 10.0 * n_from:
                return None                         # Newton diverges
            if not fresh and not nf <= 0.5 * n_from:
                if not newton_step and not nf < n_from:
                    x = x_from                      # a chord step that did not lower |f|: undone
                J, n_from, newton_step = None, np.inf, False     # a fresh Jacobian here
                continue
            newton_step, fresh, x_from, n_from = fresh, False, x, nf
            bordered = np.vstack([np.column_stack([J, -self.e_t]), b])
            x = x - np.linalg.solve(bordered, np.append(f, b @ (x - x_pred)))
            if border is None:
                x[-1] = x_pred[-1]                  # t_f exactly, not to round-off
            uses += 1
            if uses > opt.chord_steps:
                J = None

    def _point(self, tf, z, J) -> FixedTimePoint | None:
        """The converged fixed-time extremal at z: its final mass and φ = p_t(K_f)."""
        yf, ok = final_state(self.sh, jnp.asarray(z), 1.0, {**self.prm, "tf": datum(tf)})
        if not ok:
            return None
        yf = np.asarray(yf)
        return FixedTimePoint(tf, z, J, float(yf[hm.MASS]), float(yf[self.sh.model.n + hm.TIME]))

    def tangent(self, p: FixedTimePoint) -> np.ndarray:
        """A tangent (dz, dt_f) of the family at p: the null vector of [J, −e_t] (its smallest
        right singular vector; it stays defined at a fold, where J is singular and dt_f = 0)."""
        return np.linalg.svd(np.column_stack([p.J, -self.e_t]))[2][-1]

    def free_time_residual(self, z) -> float:
        """max |f| of the free-time shooting map at z (τ = 1)."""
        f, _ = residual(self.sh_free, jnp.asarray(z), 1.0, self.prm)
        return float(np.max(np.abs(np.asarray(f))))


def _interpolate(points: list[FixedTimePoint], tf: float) -> np.ndarray:
    """The start at ``tf`` inside the solved range: linear between its nearest solved neighbours."""
    below = max((p for p in points if p.tf <= tf), key=lambda p: p.tf)
    above = min((p for p in points if p.tf >= tf), key=lambda p: p.tf)
    if above.tf == below.tf:
        return below.z.copy()
    w = (tf - below.tf) / (above.tf - below.tf)
    return (1.0 - w) * below.z + w * above.z


def _crossing(last: FixedTimePoint, p: FixedTimePoint, fold: bool):
    """(left, right), two neighbours of an arclength walk in order of t_f, where φ crosses from −
    to + between them and no fold lies between them (the bracket of a local maximum of m_f in
    t_f); None otherwise."""
    left, right = sorted((last, p), key=lambda q: q.tf)
    return (left, right) if not fold and left.phi < 0.0 < right.phi else None


def hidden_slope(a: FixedTimePoint, b: FixedTimePoint) -> float:
    """The largest slope against the sign of φ at both ``a`` and ``b`` (a.tf < b.tf) of the cubic
    Hermite interpolant of m_f(t_f) through them, with the slopes dm_f/dt_f = −φ of the envelope
    relation (units of m₀ per time unit); 0 where φ changes sign between them or the interpolant
    is monotone. Positive: the four values fit no m_f monotone between them, so φ likely changes
    sign twice in (a, b) (a maximum and a minimum), the values of m_f being exact. It grows with
    how far the mean slope (m_f(b) − m_f(a))/(b − a) falls short of the slopes at the ends; a
    monotone m_f with ends more than three times steeper than its mean can show it too
    (Fritsch & Carlson 1980), which only costs a solve more.

    With s = (t − a)/h and d = −φ: h m′(s) = Δ (6s − 6s²) + h d_a (1 − 4s + 3s²) + h d_b (3s² − 2s),
    Δ = m_f(b) − m_f(a), evaluated at its vertex."""
    if np.sign(a.phi) != np.sign(b.phi):
        return 0.0
    h, delta = b.tf - a.tf, b.m_f - a.m_f
    da, db = -a.phi, -b.phi
    c2, c1, c0 = -6.0 * delta / h + 3.0 * (da + db), 6.0 * delta / h - 4.0 * da - 2.0 * db, da
    s = -c1 / (2.0 * c2) if c2 != 0.0 else -1.0
    if not 0.0 < s < 1.0:
        return 0.0
    return max(0.0, -np.sign(da) * (c2 * s * s + c1 * s + c0))


def extrapolate(trail: list[FixedTimePoint], tf: float, e_t: np.ndarray) -> np.ndarray:
    """The start at ``tf`` beyond the solved ``trail``: the polynomial in t_f through its last
    (up to three) points; from a single point its tangent dz/dt_f = J⁻¹ e_t (∂f/∂t_f = −e_t,
    ``e_t`` the time row)."""
    if len(trail) == 1:
        p = trail[0]
        return p.z + np.linalg.solve(p.J, e_t) * (tf - p.tf)
    pts = trail[-3:]
    z = np.zeros_like(pts[0].z)
    for i, p in enumerate(pts):          # Lagrange weights in t_f
        z = z + np.prod([(tf - q.tf) / (p.tf - q.tf) for j, q in enumerate(pts) if j != i]) * p.z
    return z


class MaximumSearch:
    """Steps 2–5 of the module docstring on one family; ``points`` holds every solved point at ε_f."""

    def __init__(self, family: FixedTimeFamily, tu: float, m0_kg: float):
        self.family, self.opt = family, family.opt
        self.tu, self.m0 = tu, m0_kg
        self.points: list[FixedTimePoint] = []      # at ε_f
        self.lifted: list[FixedTimePoint] = []      # at lift_eps (:meth:`across_branches`)
        self.at_lift = False                        # the family is at lift_eps
        self.budget = self.opt.max_points           # solved points (ε_f and lifted) allowed so far
        self.lift_bracket: list[float] | None = None    # days, of the lifted problem's maximum
        self.lift_failed: str | None = None         # why the lifted search found no bracket
        self.arc_points = self.folds = self.downhill = 0

    @property
    def delta(self) -> float:
        """δ, the probes' distance and the march's longest step (time units): ``probe_days``, and
        ``lift_probe_days`` while the family is lifted."""
        return (self.opt.lift_probe_days if self.at_lift else self.opt.probe_days) * DAY / self.tu

    def log(self, msg):
        if self.opt.verbose:
            print(f"[{self.opt.label}] {msg}", file=sys.stderr, flush=True)

    def days(self, tf) -> float:
        return tf * self.tu / DAY

    @property
    def kept(self) -> list[FixedTimePoint]:
        """Where solved points go: ``lifted`` while the family is lifted, else ``points``."""
        return self.lifted if self.at_lift else self.points

    def keep(self, p: FixedTimePoint, how: str = "") -> FixedTimePoint:
        self.kept.append(p)
        self.log(f"  {self.where(p.tf)}: m_f {p.m_f * self.m0:.6f} kg, phi {p.phi:+.3e}{how}")
        return p

    def where(self, tf) -> str:
        """t_f in days for the log, with the family's ε while it is lifted."""
        return f"t_f {self.days(tf):.5f} d" + (f" (eps {self.family.eps:g})" if self.at_lift else "")

    def within_budget(self) -> bool:
        return len(self.points) + len(self.lifted) < self.budget

    def solve(self, tf, start, near: FixedTimePoint | None = None) -> FixedTimePoint | None:
        """The fixed-time point at ``tf`` from ``start``, its chord steps with the Jacobian of the
        solved point ``near``; logged, and kept in ``points``."""
        p = self.family.point(tf, start, None if near is None else near.J)
        if p is None:
            self.log(f"  {self.where(tf)}: fixed-time Newton failed")
            return None
        return self.keep(p)

    def bracket(self, origin: FixedTimePoint):
        """(left, right) solved points with φ(left) < 0 < φ(right), left.tf < right.tf, or a
        reason string where none was found."""
        lo, hi = [self.advance([origin], s, self.delta)[0] for s in (-1.0, 1.0)]
        if lo is None and hi is None:
            return "neither probe at t_f +/- probe_days (down to probe_days/8) converged"
        if lo is None or hi is None:
            return self.one_sided(origin, *((lo, -1.0) if hi is None else (hi, 1.0)))
        if lo.phi < 0.0 < hi.phi:
            return (origin, hi) if origin.phi < 0.0 else (lo, origin)
        # uphill: m_f grows towards −sign φ; at a local minimum from the heavier probe
        if lo.phi > 0.0 and (hi.phi > 0.0 or lo.m_f > hi.m_f):
            return self.march([origin, lo], -1.0)
        return self.march([origin, hi], +1.0)

    def one_sided(self, origin: FixedTimePoint, probe: FixedTimePoint, side: float):
        """Only the probe on ``side`` converged: the family has no point within δ/8 on the
        other side, as at a fold of the family in t_f next to the origin (E8 500 rev: two fixed-
        time extremals at t_f − δ, none up to t_f + δ/8). From a probe uphill of the origin
        (heavier, −φ·side > 0) the march goes on in t_f; from one downhill, the family is
        followed by arclength from the origin away from it, round the fold."""
        left, right = (probe, origin) if side < 0 else (origin, probe)
        if left.phi < 0.0 < right.phi:
            return left, right
        if -probe.phi * side > 0.0 and probe.m_f > origin.m_f:
            return self.march([origin, probe], side)
        return self.follow_arc([probe, origin])

    def advance(self, trail: list[FixedTimePoint], direction: float, h: float):
        """The fixed-time point a step ``direction`` h beyond the last of ``trail``, started by
        :func:`extrapolate`; where Newton fails, or lands on another branch
        (:meth:`branch_jump`), at h/2, h/4, … down to δ/8 (E8 500 from the degenerate point: the
        family bends): (the point or None, the step it took)."""
        while True:
            tf = trail[-1].tf + direction * h
            p = self.solve(tf, extrapolate(trail, tf, self.family.e_t), trail[-1])
            if p is not None and self.branch_jump(trail[-1], p, direction):
                self.kept.remove(p)
                p = None
            if p is not None or h <= self.delta / 8:
                return p, h
            h *= 0.5

    def branch_jump(self, last: FixedTimePoint, p: FixedTimePoint, direction: float) -> bool:
        """``p``, a step in t_f from ``last`` with φ of one sign at both, has m_f moved against the
        envelope relation dm_f/dt_f = −m₀ φ by more than ``jump_tol`` (relative): no smooth
        branch joins them, Newton landed on another one. Logged; the step is retried shorter.

        Sound at ε_f only. At ε > 0 the relation fails by O(ε): at ε 1e-3 on E8 full 500 m_f rose
        about 0.2 g per 0.1 d less than −m₀φ says (docs/perturbed-e6-e7-e8.md, "thirty-fourth
        session"). The steps this check dropped there (321.059 d, −55 mg; 321.047 d, −23 mg) were
        that drift, not other branches; they sent the lifted search on to the descent that
        certified the maximum. Adding the smoothing penalty's integral Q (δ of (3.3.2) maximises
        δS + √c ε √(δ(1 − δ))) does not make it exact: the field freezes δ and differentiates H
        without the penalty, whose factor k1 depends on the state, so at ε > 0 the smoothed system
        is the Pontryagin system of no cost. Q is the first-order correction only: on perturbed E1
        (steps of 0.001 d) ΔQ is 1.0, 1.18 and 1.58 times the miss of m_f at ε 1e-4, 1e-3 and
        1e-2 ("thirty-fifth session", docs/experiments/envelope_at_eps.py)."""
        if np.sign(p.phi) != np.sign(last.phi):
            return False
        against = (p.m_f - last.m_f) * -np.sign(last.phi) * direction < -self.opt.jump_tol * abs(last.m_f)
        if against:
            self.log(f"  {self.where(p.tf)}: m_f {(p.m_f - last.m_f) * self.m0:+.3e} kg against phi's sign, "
                     "another branch: the step is retried shorter")
        return bool(against)

    def hides_roots(self, a: FixedTimePoint, b: FixedTimePoint) -> bool:
        """Two solved points with no fold between them whose m_f and φ fit no monotone m_f
        (:func:`hidden_slope`, by more than ``hidden_tol`` relative in m_f across them): φ likely
        changes sign twice between them. At ε_f only, where the envelope relation holds (at
        ε > 0 it fails by O(ε), :meth:`branch_jump`). Logged."""
        a, b = sorted((a, b), key=lambda q: q.tf)
        if self.family.eps != self.family.eps_f:
            return False
        hidden = hidden_slope(a, b) * (b.tf - a.tf) > self.opt.hidden_tol * abs(a.m_f)
        if hidden:
            self.log(f"  t_f {self.days(a.tf):.5f}-{self.days(b.tf):.5f} d: m_f and phi fit no monotone m_f, "
                     "a pair of roots of phi likely between")
        return hidden

    def same_extremal(self, p: FixedTimePoint, q: FixedTimePoint) -> bool:
        """Two solved maxima that are one extremal: t_f within δ/10, m_f within ``hidden_tol``."""
        return abs(p.tf - q.tf) <= self.delta / 10 and abs(p.m_f - q.m_f) <= self.opt.hidden_tol * abs(q.m_f)

    def march(self, trail: list[FixedTimePoint], direction: float):
        """From the last point of ``trail`` in ``direction`` by steps of the trail's last spacing
        (at most δ; halved where Newton fails, down to δ/8, and kept; at the lifted ε of
        :meth:`across_branches` doubled again after each solved point, up to δ, and at ε_f so up
        to ``max_march_days`` where that exceeds δ), until φ turns from − to + (as t_f grows);
        where a step fails even at δ/8, on by arclength (:meth:`follow_arc`)."""
        longest = self.delta if self.at_lift else max(self.delta, self.opt.max_march_days * DAY / self.tu)
        h = min(self.delta, abs(trail[-1].tf - trail[-2].tf))
        while self.within_budget():
            last = trail[-1]
            p, h = self.advance(trail, direction, h)
            if p is None:
                return self.follow_arc(trail)
            trail.append(p)
            if np.sign(p.phi) != np.sign(last.phi):
                return (last, p) if direction > 0 else (p, last)
            if self.at_lift or longest > self.delta:
                # E8 full 500 at ε 1e-3: steps of δ/4 pass 320.3 d, δ again beyond (kept at δ/4,
                # the march ran out of solves 0.2 d short of the maximum)
                h = min(2.0 * h, longest)
        return f"no sign change of phi within {self.budget} fixed-time solves"

    def arc_steps(self, trail: list[FixedTimePoint]):
        """The family followed by pseudo-arclength steps (Keller) from the last point of
        ``trail``, away from the one before it. Each solved step (its point kept) yields
        (previous point, new point, fold, dt_f/ds): dt_f/ds is the t_f component of the family's
        unit tangent at the new point, in the walk's direction. It stops where the corrector fails
        at the smallest step or the budget of solved points is spent; ``arc_end`` then says which.

        Points x = (z, t_f), inner product ⟨x, y⟩ = θ² x_z·y_z + x_t y_t with θ = |Δt_f|/|Δz| of
        the trail's last secant (its z and t_f parts weigh the same). Each step: predictor x + h v
        along the unit tangent v (:meth:`FixedTimeFamily.tangent`, oriented along the secant
        from the point before), corrector F = 0 with ⟨v, x − x_pred⟩ = 0
        (:meth:`FixedTimeFamily.correct`, from a fresh Jacobian: the tangent at the new point
        needs its own, as ∂F/∂z changes fast near a fold); h starts at a quarter of the secant's
        length, doubles after each solved step up to ``max_arc_step`` times that length, halves
        where the corrector fails (down to 1/64 of the secant). A corrected point farther than h
        from its predictor counts as a failure: the corrector's hyperplane crossed another sheet
        of the family, not the piece the step follows. Near a fold the tangent has almost no t_f
        component, so that hyperplane runs almost along t_f (E8 full 450 on the exact map, a step
        of 4 secants at the fold at 289.740 d converged 2.7 d away, at 292.470 d;
        docs/perturbed-e6-e7-e8.md, "fifty-ninth session"). A step with no fold whose m_f and φ at
        its ends fit no monotone m_f (:meth:`hides_roots`, at ε_f only) counts as a failure too:
        φ likely changed sign twice inside it, so it stepped over a maximum and a minimum, or it
        left the sheet. E7 full model, 1 N: a step of 8 secants from 87.392 to 87.867 d, φ < 0 at
        both, m_f 2.4 g lower, passed over the heaviest maximum within 1 d, 87.565 d
        ("sixty-sixth session"); from 87.828 to 88.069 d, φ > 0 at both and m_f falling, but
        far less than φ at 88.069 d says, it passed over the 87.934 d one ("sixty-seventh").
        ``fold``: the tangent's t_f component changed sign between the two points (a fold in
        t_f passed)."""
        fam = self.family
        a, last = trail[-2], trail[-1]
        secant = last.x - a.x
        theta2 = secant[-1] ** 2 / max(float(secant[:-1] @ secant[:-1]), np.finfo(float).tiny)
        inner = lambda u, w: theta2 * float(u[:-1] @ w[:-1]) + float(u[-1] * w[-1])
        length = lambda u: np.sqrt(inner(u, u))
        unit = lambda u, along: (u if inner(u, along) >= 0.0 else -u) / length(u)
        h_secant = length(secant)
        h_max = self.opt.max_arc_step * h_secant
        h, v = h_secant / 4, unit(fam.tangent(last), secant)
        self.log(f"  arclength from t_f {self.days(last.tf):.5f} d")
        self.arc_end = f"no sign change of phi within {self.budget} fixed-time solves"
        while self.within_budget():
            x_pred = last.x + h * v
            p = fam.correct(x_pred, np.append(theta2 * v[:-1], v[-1]))
            if p is not None and (off := length(p.x - x_pred)) > h:
                self.log(f"  arclength step {h / h_secant:.3g} of the secant landed at {self.where(p.tf)}, "
                         f"{off / h:.3g} steps off its predictor: another branch")
                p = None
            if p is not None:
                w = unit(fam.tangent(p), p.x - last.x)
                fold = bool(np.sign(w[-1]) != np.sign(v[-1]))
                if not fold and self.hides_roots(last, p):
                    p = None
            if p is None:
                self.log(f"  arclength step {h / h_secant:.3g} of the secant failed")
                if h <= h_secant / 64:
                    self.arc_end = f"the fixed-time family could not be followed past t_f {self.days(last.tf):.5f} d (arclength)"
                    return
                h *= 0.5
                continue
            self.arc_points += 1
            self.folds += int(fold)
            self.keep(p, ", a fold in t_f passed" if fold else "")
            yield last, p, fold, float(w[-1])
            last, v, h = p, w, min(2.0 * h, h_max)

    def follow_arc(self, trail: list[FixedTimePoint]):
        """The family followed uphill in m_f (:meth:`arc_steps`) from the last point of ``trail``,
        where steps in t_f fail: round a fold in t_f, onto the branch beyond it.

        Along the family dm_f/ds = −m₀ φ dt_f/ds (the envelope relation): the march is uphill
        while −φ dt_f/ds > 0. A fold where φ changes sign too keeps it uphill; one
        where φ keeps its sign is a maximum of m_f along the family that is no free-time
        extremal (φ ≠ 0): the search stops there, or, up to ``downhill_folds`` times, goes on
        downhill along the family until m_f rises again (past a minimum of m_f along it: a
        further fold, or a crossing of φ from + to − in t_f) and on uphill as before (E8 450
        rev, full model: the branch through the route's end point folds 0.001 d above it with
        φ ≠ 0, docs/perturbed-e6-e7-e8.md, "twenty-fourth session"). Between two points with no
        fold, a crossing of φ from − to + in t_f is the bracket of a local maximum, uphill or
        down."""
        descending = False          # on a stretch past a fold with φ ≠ 0, where m_f falls along the family
        for last, p, fold, dtf_ds in self.arc_steps(trail):
            found = _crossing(last, p, fold)
            if found:
                return found
            uphill = -p.phi * dtf_ds > 0.0
            if not uphill and not descending:
                if not (fold and self.downhill < self.opt.downhill_folds):
                    return (f"the family folds between t_f {self.days(last.tf):.5f} and {self.days(p.tf):.5f} d "
                            "with phi != 0: m_f is largest along it at the fold, no local maximum in t_f" if fold else
                            f"m_f decreases along the family at t_f {self.days(p.tf):.5f} d")
                self.downhill += 1
                self.log(f"  on downhill past the fold ({self.downhill} of {self.opt.downhill_folds})")
            descending = not uphill
        return self.arc_end

    def survey(self, best: FixedTimePoint) -> list[FixedTimePoint]:
        """The local maxima of m_f in t_f on the family through the certified maximum ``best``
        within ``survey_days`` of it, ``best`` first. The family is followed each way from a
        step of δ in t_f by arclength (:meth:`arc_steps`), through its folds, until t_f first
        leaves the window (a sheet that comes back into it is not followed) or
        ``survey_max_points`` solves are spent; each crossing of φ from − to + in
        t_f between two points with no fold between them is solved by Brent (:meth:`root`).
        A walk that brackets a maximum already found (t_f within δ/10, m_f within
        ``hidden_tol``) has turned back onto the family it came along and ends there: E7 full model, the
        upward walk from 87.565 d past 87.934 d turned at 88.562 d (a step landed just behind
        the last point, which reads as a fold) and walked down again through both
        ("sixty-seventh session").

        E8 full 500 on the exact map: the family snakes in t_f with folds 0.1–0.2 d apart, and
        the maxima at 321.52 d and 322.000 d lie on one connected family (m_f 0.6 g apart),
        which the route's blend reaches at one place or another by round-off
        (docs/perturbed-e6-e7-e8.md, "fortieth session"). The heaviest maximum of the window
        does not depend on where the route landed, as long as the window holds the others."""
        window = self.opt.survey_days * DAY / self.tu
        maxima = [best]
        for direction in (-1.0, 1.0):
            self.budget = len(self.points) + len(self.lifted) + self.opt.survey_max_points
            first, _ = self.advance([best], direction, self.delta)
            if first is None:
                self.log(f"  survey: no step from the maximum {'down' if direction < 0 else 'up'} in t_f")
                continue
            for last, p, fold, _ in self.arc_steps([best, first]):
                found = _crossing(last, p, fold)
                if found:
                    try:
                        roots = self.root(*found)
                    except _NewtonFailed as exc:
                        self.log(f"  survey: fixed-time Newton failed inside the bracket at t_f {self.days(exc.tf):.5f} d")
                    else:
                        new = [r for r in roots if not any(self.same_extremal(r, q) for q in maxima)]
                        maxima += new
                        for root in new:
                            self.log(f"  survey: a local maximum at t_f {self.days(root.tf):.5f} d, "
                                     f"m_f {root.m_f * self.m0:.6f} kg")
                        if len(new) < len(roots):
                            self.log("  survey: back at a maximum already found, the walk has turned back onto "
                                     "the family it came along: this way ends")
                            break
                if abs(p.tf - best.tf) > window:
                    break
        return maxima

    def move_eps(self, p: FixedTimePoint, eps_to: float) -> FixedTimePoint | None:
        """The fixed-time point ``p`` (at the family's ε) moved to ``eps_to`` at its t_f, in
        ``lift_steps`` log-uniform steps, each a fixed-time solve from the secant in log ε through
        the last two points, halved where Newton fails (down to 1/8); None where it fails. The
        family is left at ``eps_to`` (at the ε reached where it failed)."""
        fam = self.family
        log_to = np.log(eps_to)
        s = np.log(fam.eps)
        h = (log_to - s) / self.opt.lift_steps
        prev = None
        while abs(log_to - s) > 1e-9:
            step = h if abs(log_to - s) > abs(h) else log_to - s
            while True:
                fam.set_eps(eps_to if step == log_to - s else float(np.exp(s + step)))
                start = p.z if prev is None else p.z + (p.z - prev[1].z) * step / (s - prev[0])
                q = fam.point(p.tf, start, p.J)
                if q is not None or abs(step) <= abs(h) / 8:
                    break
                step *= 0.5
            if q is None:
                fam.set_eps(float(np.exp(s)))
                self.log(f"  eps {fam.eps:g} -> {np.exp(s + step):g} at t_f {self.days(p.tf):.5f} d: fixed-time Newton failed")
                return None
            prev, p, s = (s, p), q, s + step
            self.log(f"  eps {fam.eps:.3g} at t_f {self.days(p.tf):.5f} d: m_f {p.m_f * self.m0:.6f} kg, phi {p.phi:+.3e}")
        return p

    def across_branches(self, origin: FixedTimePoint, reason: str):
        """Where the search at ε_f brackets no maximum (``reason``), the search again through the
        family at the larger smoothing ε = ``lift_eps``: (left, right) at ε_f as :meth:`bracket`
        returns them, or a reason string.

        At ε_f the fixed-time family can fold with φ ≠ 0 where a burn arc is about to be born
        (E8 full model 500: at 320.262 d, S grazing −5e-5 one revolution before the shortest
        arcs; docs/perturbed-e6-e7-e8.md, "thirtieth" and "thirty-second session"); branches
        beyond it with maxima exist but steps in t_f cannot reach them. With wider switches the
        family at a larger ε runs on past such places. So: the origin is moved to ``lift_eps`` at
        its t_f (:meth:`move_eps`), the bracket search runs there (probes, march, arclength:
        :meth:`bracket`) to the lifted problem's maximum, its bracket point with the smaller |φ|
        is moved back to ε_f at its t_f, and the bracket search at ε_f runs from where it lands.
        The search at ``lift_eps`` has probes ``lift_probe_days`` apart and ``lift_max_points``
        fixed-time solves, the one back at ε_f ``max_points`` more. The maximum found lies on whatever
        branch the descent lands on: it is certified as a local maximum of m_f in t_f at ε_f, as
        any other, not as the heaviest."""
        opt, fam = self.opt, self.family
        self.log(f"  no maximum at eps {fam.eps_f:g} ({reason}); the family at eps {opt.lift_eps:g} from "
                 f"t_f {self.days(origin.tf):.5f} d")
        try:
            return self._across_branches(origin, reason)
        finally:        # whatever happened, the family is left at ε_f (the record's free-time residual)
            fam.set_eps(fam.eps_f)
            self.at_lift = False

    def _across_branches(self, origin: FixedTimePoint, reason: str):
        """The steps of :meth:`across_branches`, which restores ε_f and the lift flag (and so δ) after them."""
        opt, fam = self.opt, self.family
        lifted = self.move_eps(origin, opt.lift_eps)
        if lifted is None:
            return f"{reason}; the lift to eps {opt.lift_eps:g} failed"
        self.at_lift = True
        self.lifted.append(lifted)
        self.budget = len(self.points) + len(self.lifted) + opt.lift_max_points
        found = self.bracket(lifted)
        if isinstance(found, str):
            # no bracket at the lifted ε either: descend where φ came closest to zero there (E8
            # full 500, scratch: lifted φ −7.4e-8 at 321.040 d, +2.8e-8 back at ε_f, the
            # maximum 0.012 d away); a maximum found from there is certified at ε_f as any other
            near = min(self.lifted, key=lambda q: abs(q.phi))
            self.lift_failed = found
            self.log(f"  at eps {opt.lift_eps:g}: {found}; back to eps {fam.eps_f:g} where |phi| is least, "
                     f"{self.days(near.tf):.5f} d")
        else:
            near = min(found, key=lambda q: abs(q.phi))
            self.lift_bracket = [self.days(q.tf) for q in found]
            self.log(f"  at eps {opt.lift_eps:g} a maximum between {self.lift_bracket[0]:.5f} and "
                     f"{self.lift_bracket[1]:.5f} d; back to eps {fam.eps_f:g} at {self.days(near.tf):.5f} d")
        landed = self.move_eps(near, fam.eps_f)
        self.at_lift = False
        if landed is None:
            return f"{reason}; the descent from eps {opt.lift_eps:g} at t_f {self.days(near.tf):.5f} d failed"
        self.points.append(landed)
        self.budget = len(self.points) + len(self.lifted) + opt.max_points
        found = self.bracket(landed)
        return found if not isinstance(found, str) else f"{reason}; after the lift, from t_f {self.days(landed.tf):.5f} d: {found}"

    def root(self, left: FixedTimePoint, right: FixedTimePoint) -> list[FixedTimePoint]:
        """The crossings of φ from − to + in [left, right] that its solves reveal, as solved
        points, heaviest first. Brent first; then the bracket's solved points are read again in
        order of t_f: a neighbouring pair with φ from − to + and no root yet between them is
        another crossing, solved by Brent in turn; a pair whose values of m_f and φ fit no
        monotone m_f (:meth:`hides_roots`) likely hides a pair of roots, and its midpoint is
        solved (at most ``bracket_splits`` of them). A bracket can hold three roots, two maxima
        and the minimum between them: E7 full model, 87.54–88.10 d ("sixty-seventh session"),
        where Brent alone returns one maximum or the other by where its iterates fall. The
        starts are interpolated between the bracket's own points only: where the family folds,
        other solved points in that range of t_f lie on another branch."""
        pool, roots, splits = [left, right], [], 0
        xtol = self.opt.tof_tol_days * DAY / self.tu

        def phi(tf):
            p = next((q for q in pool if q.tf == tf), None)
            if p is None:
                p = self.solve(tf, _interpolate(pool, tf), min(pool, key=lambda q: abs(q.tf - tf)))
                if p is None:
                    raise _NewtonFailed(tf)
                pool.append(p)
            return p.phi

        def brent(a, b):
            tf = brentq(phi, a.tf, b.tf, xtol=xtol, maxiter=40)
            roots.append(min(pool, key=lambda p: abs(p.tf - tf)))

        brent(left, right)
        while True:
            ordered = sorted(pool, key=lambda p: p.tf)
            pairs = [(a, b) for a, b in zip(ordered, ordered[1:]) if b.tf - a.tf > 2.0 * xtol]
            crossing = next(((a, b) for a, b in pairs if a.phi < 0.0 < b.phi
                             and not any(a.tf <= r.tf <= b.tf for r in roots)), None)
            hidden = next(((a, b) for a, b in pairs if self.hides_roots(a, b)),
                          None) if crossing is None and splits < self.opt.bracket_splits else None
            if crossing is not None:
                self.log(f"  another crossing of phi inside the bracket, {self.days(crossing[0].tf):.5f}"
                         f"-{self.days(crossing[1].tf):.5f} d")
                brent(*crossing)
            elif hidden is not None:
                splits += 1
                phi(0.5 * (hidden[0].tf + hidden[1].tf))
            else:
                return sorted(roots, key=lambda p: -p.m_f)


class _NewtonFailed(Exception):
    def __init__(self, tf):
        self.tf = tf


def maximise_final_mass(sol, options: MaximumOptions | None = None):
    """The local maximum of m_f in t_f next to the free-time solution ``sol`` (a perturbed OT
    :class:`~.chain.Solution` at τ = 1): (solution, record). The solution is the fixed-time
    extremal at the maximum, or ``sol`` unchanged where the search failed (record 'status')."""
    opt = options or MaximumOptions()
    tr, start = sol.transfer, time.perf_counter()
    family = FixedTimeFamily(sol.shooting, sol.prm, opt)
    search = MaximumSearch(family, tr.tu, tr.m0)
    t0 = family.end_time(sol.z)
    search.log(f"free-time end game: t_f {search.days(t0):.5f} d, probes at +/- {opt.probe_days:g} d")
    record = {"probe_days": opt.probe_days, "t0_days": search.days(t0)}
    origin = search.solve(t0, sol.z)
    out, status = sol, "maximum"
    if origin is None:
        status = "the fixed-time extremal at the solution's own t_f did not converge"
    else:
        record["m_f0_kg"] = origin.m_f * tr.m0
        found = search.bracket(origin)
        if isinstance(found, str) and sol.shooting.switching == "exact":
            record["lift"] = {"eps": None, "off": "the exact bang-bang map has no smoothing eps to lift"}
        elif isinstance(found, str) and opt.lift_eps > 0.0:
            found = search.across_branches(origin, found)
            record["lift"] = {"eps": opt.lift_eps, "bracket_days": search.lift_bracket, "failed": search.lift_failed,
                              "points": [[search.days(p.tf), p.m_f * tr.m0, p.phi]
                                         for p in sorted(search.lifted, key=lambda p: p.tf)]}
        if isinstance(found, str):
            status = found
        else:
            left, right = found
            record["bracket_days"] = [search.days(left.tf), search.days(right.tf)]
            try:
                found = search.root(left, right)
            except _NewtonFailed as exc:
                status = f"fixed-time Newton failed inside the bracket at t_f {search.days(exc.tf):.5f} d"
            else:
                best = found[0]
                if len(found) > 1:
                    record["bracket_maxima"] = [[search.days(p.tf), p.m_f * tr.m0, p.phi] for p in found]
                if opt.survey_days > 0.0:
                    maxima = search.survey(best)
                    maxima += [p for p in found[1:] if not any(search.same_extremal(p, q) for q in maxima)]
                    record["survey"] = {"window_days": opt.survey_days, "first_tof_days": search.days(best.tf),
                                        "maxima": [[search.days(p.tf), p.m_f * tr.m0, p.phi]
                                                   for p in sorted(maxima, key=lambda p: p.tf)]}
                    best = max(maxima, key=lambda p: p.m_f)
                out = dataclasses.replace(sol, z=best.z, stats=dict(sol.stats))
                record.update({"tof_days": search.days(best.tf), "m_f_kg": best.m_f * tr.m0,
                               "m_f_gain_kg": (best.m_f - origin.m_f) * tr.m0, "phi": best.phi})
    record.update({"status": status, "certified": status == "maximum",
                   "points": [[search.days(p.tf), p.m_f * tr.m0, p.phi]
                              for p in sorted(search.points, key=lambda p: p.tf)],
                   "fixed_time_solves": family.solves, "jacobian_evaluations": family.jacobians,
                   "arclength_points": search.arc_points, "folds_passed": search.folds,
                   "downhill_folds_passed": search.downhill,
                   "residual_evaluations": family.residuals,
                   "free_time_residual": family.free_time_residual(out.z),
                   "wall_time_s": time.perf_counter() - start})
    search.log(f"free-time end game: {status}" + (
        f", t_f {record['tof_days']:.5f} d, m_f {record['m_f_kg']:.6f} kg ({record['m_f_gain_kg'] * 1e3:+.2f} g)"
        if "tof_days" in record else ""))
    return out, record
