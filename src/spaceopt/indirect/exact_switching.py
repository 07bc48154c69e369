"""The minimum-fuel shooting map with the exact bang-bang throttle δ = 1[S > 0] and its Jacobian.

Why: the smoothed throttle δ(S, ε) (3.3.2) turns from 0 to 1 over |S| ≲ ε, and at ε_f = 1e-5
Dopri8's error control resolves each of these steep transitions with many small steps: three
quarters of the steps of an E8 500 propagation (56 541 at ε_f against 14 084 at ε = 0.1) go into
the 1 043 switches, not the orbit (docs/perturbed-e6-e7-e8.md, "thirtieth session"). The exact
map is the limit ε → 0 the smoothing approximates; its extremal agrees with ε = 1e-7 a hundred to
a thousand times better than ε_f's does.

The map, for a pure OT model (``Model('ot', h)`` with h ≠ 'lp': the end-point problem, the
force-model blend 'model', the perturbation switch 'pert', a parameter path 'param'):

1. **Switches by events** (pass 1, y alone). Each arc is integrated with δ fixed (0 or 1) in
   segments of at most ``SEGMENT_STEPS`` Dopri8 steps; a diffrax event stops a segment at the
   first step end where (2δ − 1) S < −η (the throttle on the wrong side; η = ``S_NOISE``, or
   twice |S| at the arc's start where the stepped state misses S = 0 by more). S is sampled
   on the segment's dense output (8th order), ``SAMPLES_PER_STEP`` points in every step, with its
   K derivative (forward mode through the interpolant), so an arc shorter than a step (S across
   zero and back between two step ends, which the event cannot see) is caught too: by a sample on
   the wrong side, or, for an arc shorter than a sample interval, by the extremum of S between
   two samples reaching zero (:func:`_crossing`). An arc is thus seen from its birth (the
   extremum at zero), not once a sample first falls in it. The first such place brackets the
   switch K_s, which bisection on the interpolant locates; y(K_s) is then stepped from the last
   accepted step point before K_s (the interpolant's own error, summed over a thousand switches,
   moved t(K_f) by 3e-5 TU at E8 500). diffrax's own event root find was tried in the spike and
   stopped at its iteration limit on a tenth of the arcs at E8 500, returning times up to 6 rad off.
2. **Sensitivities with saltation** (pass 2). (y, Φ), Φ = ∂y/∂(z, τ), are integrated over the
   arcs of pass 1 with δ fixed, Φ' = g_y Φ (+ g_τ), and at each switch

       dK_s/dp = −(∇_y S · Φ⁻_p + ∂S/∂p) / (∂S/∂K + ∇_y S · g⁻),    Φ⁺ = Φ⁻ + (g⁻ − g⁺) dK_s/dp,

   the jump of the sensitivities across the discontinuity of the field (the saltation matrix).
3. The residual and Jacobian are assembled as :func:`.shooting._shoot` does, with δ fixed at its
   K = 0 value in the transversality condition and δ of the last arc in the K_f column. f is
   pass 1's y(K_f), the same as :func:`residual`'s; pass 2 may integrate at a looser tolerance
   (``Shooting.sensitivity_rtol``), since Newton needs ∂f/∂z only to ‖J⁻¹ δJ‖ ≪ 1: at the E8
   500 full-model blend ‖J⁻¹ δJ‖ is 0.23 at 1e-9 against 1e-11, and the Jacobian 1.41× cheaper.

Both passes run inside one compiled ``lax.while_loop`` each; each piece of a pass (arc, segment,
restep to a switch) starts from the step carried from the piece before (``CARRY_STEPS``).
Written by hand because diffrax integrates one smooth field per solve: the arc loop, the
bracketing and the saltation are the standard treatment of a field discontinuous across a
switching surface. A switch where S is tangent to zero (∂S/∂K + ∇_y S · g⁻ → 0: an arc being
born or dying) makes dK_s/dz unbounded: the map is continuous there but not differentiable (an
arc's width grows as the square root of its S extremum), nothing here detects that, and the
success flag stays true. Paths through such places may crawl: that is what the smoothing is for,
and the caller's choice (case option ``switching``). (The E8 500 4×4 → full blend's crawl near τ
0.17, first read as such a place, is not one: the switch count stays fixed there while Newton
diverges, cond(∂f/∂z) 1.5e7; the case's truncated-SVD steps take it through;
docs/perturbed-e6-e7-e8.md, "thirty-eighth session".)
The spike and its measurements: docs/experiments/e8_exact_switching.py.
"""
from __future__ import annotations

from functools import partial

import diffrax
import jax
import jax.numpy as jnp

from . import column_threads, hamiltonians as hm
from .flow import (STEP_BOUND, StepMemory, capped, field, field_with_tangents, hamiltonian, ot_delta, padded_samples,
                   params_at, require_success, step_control, uniform_samples)
from .shooting import _start_jit, initial_state, terminal_residual, terminal_with_derivatives
from .transfer import datum

SEGMENT_STEPS = 32        # Dopri8 steps per segment of pass 1 (sizes its dense output)
SAMPLES_PER_STEP = 8      # samples of S per step of a segment (arcs shorter than a step)
S_NOISE = 1e-10           # |S| of the integration error at a switch (S is of order 1e-2 at E8)
MAX_SWITCHES = 8192       # capacity of the switch list (E8 500: 1 043)
BISECTIONS = 60           # halvings of the bracketing sample interval (≤ 0.05 rad → 4e-20 rad)
RESTEP_STEPS = 64          # step cap of y(K_s) stepped from the last step point (within one step)
# Each piece of a pass (an arc, a segment) starts with the step the controller proposed at the end
# of the piece before (flow.StepMemory; y(K_s) in one step from the last step point), instead of
# diffrax's initial-step rule. The first piece starts with this probe, rad of K: the controller
# grows it at most tenfold a step (E8: steps of ~0.2 rad), or shrinks it where it is too long.
# E8 500, the J2 -> full blend at τ 0.5: pass 1 in 11 673 steps instead of 14 580 (1.17x faster),
# the Jacobian in 17 772 instead of 21 966 (1.18x), paired medians side by side; the blend's whole
# path and polish 1.12-1.23x, the same 44 Jacobians and extremal (docs/experiments/exact_step_carry.py)
FIRST_STEP = 1e-3
CARRY_STEPS = True         # False: every piece from diffrax's initial-step rule (the experiment's baseline)
# |f| where Newton on the exact map stops improving: the integration error summed over a thousand
# arcs (E8 500 rev, end-point tolerances: 1e-10 … 2e-10 after 12 polish iterations, the 4×4
# blend; 7.7e-11 in the spike); the followers' final polish stops here (chain._polish_floor)
TOL_FINAL = 1e-9
# Before _crossing bracketed arcs shorter than a sample interval, the map had edges: E8 200 rev,
# the jump from ε₁, the switch count flipped 366 ↔ 368 with steps of 1e-11 and |f| by 5.6e-5, as
# the samples fell in or beside an arc 0.072 rad wide (S maximum 5.8e-5, S'' −0.091, at K 885.9);
# Newton from one side stalled at 1.0e-7. At 15 random perturbations of 1e-11 of that root the old
# pass 1 gave 366 switches 10 times (|f| up to 5e-5), this one 368 every time (|f| ≤ 1.4e-10).
# The final polish may still step across an edge this many times (chain._polish_floor;
# ContinuationOptions.polish_crossings), for what is left: an arc born flat, whose existence the
# integration error of S decides
POLISH_CROSSINGS = 1

RUNNING, DONE, NO_CROSSING, TOO_MANY_SWITCHES, STEP_LIMIT, INTEGRATION_FAILED = range(6)
STATUS = ("running", "done", "event without a crossing", "switch list full", "step limit reached",
          "integration failed")


@partial(jax.jit, static_argnums=0)
def switching(model, K, y, tau, prm):
    """S(K, y) of the OT throttle at τ, the problem data moved along a 'param' path."""
    return ot_delta(model, K, y, tau, params_at(model, prm, tau))[1]


def throttle_at(model, K, y, tau, prm):
    """δ = 1[S > 0] (a constant for the derivatives)."""
    return jax.lax.stop_gradient(jnp.where(switching(model, K, y, tau, prm) > 0, 1.0, 0.0))


def _arc_rhs(model):
    return lambda K, y, a: field(model, K, y, a[0], a[1], delta=a[2])


def _first_step(dt):
    """dt0 of a piece of a pass: ``dt`` (the step carried from the piece before), or diffrax's
    initial-step rule where CARRY_STEPS is off."""
    return dt if CARRY_STEPS else None


def _segment(model, K, Kf, y, delta, noise, tau, prm, rtol, atol, segment_steps, dt):
    """At most ``segment_steps`` steps of the arc with throttle δ from K toward K_f, the first of
    ``dt``, stopped at the first step end where (2δ − 1) S < −``noise``; dense output kept, and
    the controller's proposals (:class:`.flow.StepMemory`)."""
    def wrong_side(t, yy, args, **_):
        return (2.0 * args[2] - 1.0) * switching(model, t, yy, args[0], args[1]) < -args[3]
    return diffrax.diffeqsolve(
        diffrax.ODETerm(_arc_rhs(model)), diffrax.Dopri8(), t0=K, t1=Kf, dt0=_first_step(dt), y0=y,
        args=(tau, prm, delta, noise), stepsize_controller=StepMemory(step_control(rtol, atol, segment_steps)),
        saveat=diffrax.SaveAt(t1=True, dense=True, controller_state=True), max_steps=segment_steps,
        throw=False, event=diffrax.Event(wrong_side))


def _side(model, sol, delta, tau, prm):
    """k ↦ (2δ − 1) S on the segment's dense output: positive on the throttle's own side of S = 0."""
    return lambda k: (2.0 * delta - 1.0) * switching(model, k, sol.evaluate(k), tau, prm)


def _bisect(before, a, b):
    """The point of [a, b] where ``before`` turns from true to false, by ``BISECTIONS`` halvings."""
    def halve(_, ab):
        m = 0.5 * (ab[0] + ab[1])
        ok = before(m)
        return jnp.where(ok, m, ab[0]), jnp.where(ok, ab[1], m)
    a, b = jax.lax.fori_loop(0, BISECTIONS, halve, (a, b))
    return 0.5 * (a + b)


def _extremum(slope, a, b, minimum):
    """K of the extremum in [a, b] where ``slope`` changes sign (− to + for a minimum)."""
    return _bisect(lambda m: slope(m) < 0 if minimum else slope(m) > 0, a, b)


def _crossing(model, sol, K, Kend, delta, tau, prm):
    """(crossed, K_a, K_b): the first place after K where the throttle passes from the right
    side of S = 0 (K_a) to the wrong side (K_b).

    Three ways, the earliest taken: (i) an arc born at K that ends before the first sample (the
    side rises from K, the first sample lies past its maximum and on the wrong side); (ii) a
    sample on the wrong side after one on the right side; (iii) between two samples on the right
    side, a minimum of the side that reaches zero (an arc of the other throttle shorter than a
    sample interval: screened by the tangents at the two samples, which bound a convex side from
    below, then located by bisection on the slope). Without (i) and (iii) an arc is seen only once
    a sample falls in it, so f jumps as the samples move in or beside an arc shorter than a sample
    interval (E8 200 rev: an arc 0.072 rad wide, |f| 5e-5 apart), and the segment after a switch
    fails where the new arc ends before its first sample; with them an arc is seen from the moment
    the extremum of S reaches zero."""
    side = _side(model, sol, delta, tau, prm)
    side_slope = lambda k: jax.jvp(side, (k,), (jnp.ones_like(k),))  # noqa: E731
    slope = lambda k: side_slope(k)[1]  # noqa: E731
    ts = sol.interpolation.ts
    a, b = ts[:-1], ts[1:]
    valid = b <= Kend                                     # steps taken (the padding is +inf)
    frac = jnp.arange(1, SAMPLES_PER_STEP + 1) / SAMPLES_PER_STEP
    ks = jnp.where(valid[:, None], a[:, None] + (b - a)[:, None] * frac[None, :], Kend).ravel()
    valid = jnp.repeat(valid, SAMPLES_PER_STEP)
    s, d = jax.vmap(side_slope)(ks)
    idx = jnp.arange(ks.size)
    # (ii) a wrong-side sample after a right-side one (samples before the first right-side one
    # lie in the integration noise just after a switch)
    right = valid & (s > 0)
    first_right = jnp.where(jnp.any(right), jnp.argmax(right), ks.size)
    below = valid & (s <= 0) & (idx > first_right)
    j = jnp.where(jnp.any(below), jnp.argmax(below), ks.size)
    # (iii) candidates: a minimum between two right-side samples, before the sample crossing,
    # whose tangent lines meet at or below half the smaller sample
    s0, s1, d0, d1, h = s[:-1], s[1:], d[:-1], d[1:], ks[1:] - ks[:-1]
    meet = s0 + d0 * (s1 - s0 - d1 * h) / jnp.where(d0 < d1, d0 - d1, -1.0)
    hidden = (right[:-1] & right[1:] & (d0 < 0) & (d1 > 0) & (meet <= 0.5 * jnp.minimum(s0, s1))
              & (idx[:-1] + 1 < j))

    def next_candidate(c):
        start, _, _, _ = c
        i = jnp.argmax(hidden & (idx[:-1] >= start))
        km = _extremum(slope, ks[i], ks[i + 1], True)
        return i + 1, side_slope(km)[0] <= 0, ks[i], km

    def more(c):
        return ~c[1] & jnp.any(hidden & (idx[:-1] >= c[0]))
    _, found, Ka_hidden, Kb_hidden = jax.lax.while_loop(more, next_candidate, (0, False, K, K))
    # (i) the arc born at K ends before the first sample
    dK = side_slope(K)[1]
    short = valid[0] & (s[0] <= 0) & (dK > 0) & (d[0] < 0)

    def short_arc(_):
        km = _extremum(slope, K, ks[0], False)
        return km, jnp.where(side_slope(km)[0] > 0, ks[0], km)
    Ka_short, Kb_short = jax.lax.cond(short, short_arc, lambda _: (K, K), None)
    Ka_plain, Kb_plain = jnp.where(j > 0, ks[j - 1], K), ks[jnp.minimum(j, ks.size - 1)]
    Ka = jnp.where(short, Ka_short, jnp.where(found, Ka_hidden, Ka_plain))
    Kb = jnp.where(short, Kb_short, jnp.where(found, Kb_hidden, Kb_plain))
    return short | found | (j < ks.size), Ka, Kb


def _locate(model, sol, Ka, Kb, delta, tau, prm, rtol, atol):
    """K_s by bisection on the dense output, and y(K_s) stepped from the last step point before it
    (one step, shorter than the accepted step there)."""
    side = _side(model, sol, delta, tau, prm)
    Ks = _bisect(lambda k: side(k) > 0, Ka, Kb)
    ts = sol.interpolation.ts
    tj = ts[jnp.maximum(jnp.searchsorted(ts, Ks, side="right") - 1, 0)]
    out = diffrax.diffeqsolve(
        diffrax.ODETerm(_arc_rhs(model)), diffrax.Dopri8(), t0=tj, t1=Ks, dt0=_first_step(Ks - tj),
        y0=sol.evaluate(tj), args=(tau, prm, delta), stepsize_controller=step_control(rtol, atol, RESTEP_STEPS),
        saveat=diffrax.SaveAt(t1=True), max_steps=RESTEP_STEPS, throw=False)
    return Ks, out.ys[-1], out.stats["num_steps"]


def switches(model, y0, Kf, tau, prm, rtol, atol, max_steps, segment_steps=SEGMENT_STEPS):
    """Pass 1: a dict with δ on the first arc ``d0``, the switch points ``Ks`` (the first
    ``n_switches`` entries of a MAX_SWITCHES array, the rest K_f), y(K_f) ``yf``, ``steps``
    and ``status`` (an index into STATUS)."""
    d0 = throttle_at(model, 0.0, y0, tau, prm)

    def step(c):
        K, y, delta, noise, Ks, n_sw, steps, status, dt = c
        sol = _segment(model, K, Kf, y, delta, noise, tau, prm, rtol, atol, segment_steps, dt)
        Kend, yend = sol.ts[-1], sol.ys[-1]
        dt = StepMemory.proposals(sol.controller_state)[0]    # the next step past a segment's end or a switch
        steps = steps + sol.stats["num_steps"]
        crossed, Ka, Kb = _crossing(model, sol, K, Kend, delta, tau, prm)

        def switch(_):
            Ks_, ys_, st = _locate(model, sol, Ka, Kb, delta, tau, prm, rtol, atol)
            full = n_sw + 1 >= MAX_SWITCHES
            # the stepped state misses S = 0 by the integration error: the next arc's event
            # threshold lies beyond it (rtol 1e-8 on E1: |S| 1.8e-9 after a switch)
            noise_ = jnp.maximum(S_NOISE, 2.0 * jnp.abs(switching(model, Ks_, ys_, tau, prm)))
            return (Ks_, ys_, 1.0 - delta, noise_, Ks.at[n_sw].set(Ks_), n_sw + 1, steps + st,
                    jnp.where(full, TOO_MANY_SWITCHES, RUNNING))

        def go_on(_):
            res = sol.result
            status_ = jnp.where(
                res == diffrax.RESULTS.successful, DONE,
                jnp.where(res == diffrax.RESULTS.max_steps_reached, RUNNING,
                          jnp.where(res == diffrax.RESULTS.event_occurred, NO_CROSSING, INTEGRATION_FAILED)))
            return Kend, yend, delta, noise, Ks, n_sw, steps, status_

        out = jax.lax.cond(crossed, switch, go_on, None)
        return (*out[:7], jnp.where((out[7] == RUNNING) & (out[6] > max_steps), STEP_LIMIT, out[7]), dt)

    init = (jnp.asarray(0.0), y0, d0, jnp.asarray(S_NOISE), jnp.full(MAX_SWITCHES, Kf), jnp.asarray(0),
            jnp.asarray(0), jnp.asarray(RUNNING), jnp.asarray(FIRST_STEP))
    K, y, _, _, Ks, n_sw, steps, status, _ = jax.lax.while_loop(lambda c: c[7] == RUNNING, step, init)
    return dict(d0=d0, Ks=Ks, n_switches=n_sw, yf=y, steps=steps, status=status)


def _saltation(model, K, y, Phi, delta, tau, prm, tau_tangent):
    """Φ⁺ = Φ⁻ + (g⁻ − g⁺) dK_s/d(z, τ) at a switch from throttle δ (``tau_tangent``: each
    column's weight of ∂/∂τ)."""
    g_minus = field(model, K, y, tau, prm, delta=delta)
    g_plus = field(model, K, y, tau, prm, delta=1.0 - delta)
    S_K, S_y, S_tau = jax.grad(lambda k, yy, t: switching(model, k, yy, t, prm), argnums=(0, 1, 2))(K, y, tau)
    dKs = -(S_y @ Phi + S_tau * tau_tangent) / (S_K + S_y @ g_minus)
    return Phi + jnp.outer(g_minus - g_plus, dKs)


def propagate_with_sensitivities(model, y0, Phi0, Kf, tau, prm, rtol, atol, max_steps, d0, Ks, n_switches,
                                 tau_tangent=None):
    """Pass 2: y(K_f), Φ(K_f), δ on the last arc, steps, success; the τ column of Φ last, or,
    with ``tau_tangent``, each column's weight of ∂/∂τ (a block of columns, .column_threads)."""
    if tau_tangent is None:
        tau_tangent = jnp.zeros(Phi0.shape[1]).at[-1].set(1.0)

    def rhs(K, Y, a):
        return field_with_tangents(lambda yy, tt: field(model, K, yy, tt, a[1], delta=a[2]), Y[0], a[0], Y[1],
                                   tau_tangent)

    controller = StepMemory(step_control(rtol, atol, max_steps))

    def arc(c):
        i, K, y, Phi, delta, steps, ok, dt = c
        K1 = Ks[i]                                   # K_f past the last switch
        sol = diffrax.diffeqsolve(
            diffrax.ODETerm(rhs), diffrax.Dopri8(), t0=K, t1=K1, dt0=_first_step(dt), y0=(y, Phi),
            args=(tau, prm, delta), stepsize_controller=controller,
            saveat=diffrax.SaveAt(t1=True, controller_state=True), max_steps=STEP_BOUND, throw=False)
        y, Phi = sol.ys[0][-1], sol.ys[1][-1]
        last = i >= n_switches
        Phi = jax.lax.cond(last, lambda: Phi, lambda: _saltation(model, K1, y, Phi, delta, tau, prm, tau_tangent))
        # the step proposed before the arc's last one, which was cut short at the switch
        dt = StepMemory.proposals(sol.controller_state)[1]
        return (i + 1, K1, y, Phi, jnp.where(last, delta, 1.0 - delta), steps + sol.stats["num_steps"],
                ok & (sol.result == diffrax.RESULTS.successful), dt)

    init = (jnp.asarray(0), jnp.asarray(0.0), y0, Phi0, d0, jnp.asarray(0), jnp.asarray(True),
            jnp.asarray(FIRST_STEP))
    _, _, yf, Phif, d_last, steps, ok, _ = jax.lax.while_loop(
        lambda c: (c[0] <= n_switches) & c[6], arc, init)
    return yf, Phif, d_last, steps, ok


def transversality(sh, z, tau, prm, delta):
    """p_LK(0) + H(0) with the throttle δ fixed at its K = 0 value."""
    y0 = initial_state(sh, z, params_at(sh.model, prm, tau))
    return y0[sh.model.n + hm.LK] + hamiltonian(sh.model, 0.0, y0, tau, prm, delta=delta)


@partial(jax.jit, static_argnums=0)
def _pass1(sh, z, tau, prm, rtol, atol, max_steps):
    """Pass 1 (:func:`switches`) from the unknowns z of the layout ``sh``: one compiled program
    per layout that the residual, y(K_f), the switch list, the Jacobian and the dense trajectory
    share (fused into each of them, pass 1 was compiled five times: 14 s each on E1 J2)."""
    y0 = initial_state(sh, z, params_at(sh.model, prm, tau))
    return switches(sh.model, y0, z[sh.kf_index], tau, prm, rtol, atol, max_steps)


@partial(jax.jit, static_argnums=0)
def _residual_of(sh, z, tau, prm, p1):
    """f(z, τ) and the success flag from pass 1's output."""
    r_term = terminal_residual(sh, p1["yf"], z[sh.kf_index], params_at(sh.model, prm, tau), tau)
    f = jnp.concatenate([jnp.atleast_1d(transversality(sh, z, tau, prm, p1["d0"])), r_term])
    return f, p1["status"] == DONE


def residual(sh, z, tau, prm, rtol, atol):
    """f(z, τ) of the exact map, and the success flag (pass 1 only)."""
    return _residual_of(sh, z, tau, prm, _pass1(sh, z, tau, prm, rtol, atol, sh.max_steps))


def final_state(sh, z, tau, prm, rtol, atol):
    """y(K_f) of the exact map, and the success flag."""
    p1 = _pass1(sh, z, tau, prm, rtol, atol, sh.max_steps)
    return p1["yf"], p1["status"] == DONE


@partial(jax.jit, static_argnums=0)
def _assemble(sh, z, tau, prm, yf, Phif, d_last, d0):
    """f(z, τ), ∂f/∂z, ∂f/∂τ from y(K_f), Φ(K_f) and the throttle on the first and last arcs."""
    kf, model = sh.kf_index, sh.model
    gf = field(model, z[kf], yf, tau, prm, delta=d_last)
    r_term, dr_dy, dr_dK, dr_dtau = terminal_with_derivatives(sh, yf, z[kf], tau, prm)
    dyf_dz = jnp.insert(Phif[:, :-1], kf, gf, axis=1)
    J_term = (dr_dy @ dyf_dz).at[:, kf].add(dr_dK)
    ftau_term = dr_dy @ Phif[:, -1] + dr_dtau

    r0_of = lambda zz, tt: transversality(sh, zz, tt, prm, d0)  # noqa: E731
    r0 = r0_of(z, tau)
    dr0_dz, dr0_dtau = jax.jacfwd(r0_of, argnums=(0, 1))(z, tau)
    f = jnp.concatenate([jnp.atleast_1d(r0), r_term])
    J = jnp.concatenate([dr0_dz[None, :], J_term], axis=0)
    ftau = jnp.concatenate([jnp.atleast_1d(dr0_dtau), ftau_term])
    return f, J, ftau


_pass2_block = jax.jit(propagate_with_sensitivities, static_argnums=0)


def shoot(sh, z, tau, prm, rtol, atol, sens_rtol, sens_atol, k=1):
    """f(z, τ), ∂f/∂z, ∂f/∂τ, steps of both passes, success (:func:`.shooting.shoot`'s tuple).

    f and the K_f column come from pass 1 at (rtol, atol), as in :func:`residual`; pass 2
    integrates the sensitivities at (sens_rtol, sens_atol) (``Shooting.sensitivity_rtol``), with
    its columns split over ``k`` threads where k > 1 (.column_threads). Each pass is a compiled
    program of its own; under a JAX transformation they trace into one computation."""
    p1 = _pass1(sh, z, tau, prm, rtol, atol, sh.max_steps)
    y0, Phi0 = _start_jit(sh, z, tau, prm)       # y(0), Φ(0) as on the smoothed map

    def block(Phi, tangent):
        return _pass2_block(sh.model, y0, Phi, z[sh.kf_index], tau, prm, sens_rtol, sens_atol, sh.max_steps,
                            p1["d0"], p1["Ks"], p1["n_switches"], tangent)
    if k > 1:
        _, Phif, d_last, steps2, ok2 = column_threads.propagate(block, Phi0, k)
    else:
        _, Phif, d_last, steps2, ok2 = block(Phi0, None)       # the τ column last (pass 2's default)
    return (*_assemble(sh, z, tau, prm, p1["yf"], Phif, d_last, p1["d0"]), p1["steps"] + steps2,
            ok2 & (p1["status"] == DONE))


shoot_threaded = shoot     # .shooting.shoot's name for the map with k > 1 threads (k: shoot's last argument)


def switch_points(sh, z, tau, prm, rtol, atol):
    """Pass 1's switches of the unknowns z: (δ on the first arc, K_s array, count, status); τ a
    datum, as in :func:`.shooting.shoot` (pass 1 is the program of the map's)."""
    p1 = _pass1(sh, z, datum(tau), prm, rtol, atol, sh.max_steps)
    return p1["d0"], p1["Ks"], p1["n_switches"], p1["status"]


def dense(sh, z, tau, prm, n, max_steps, rtol=1e-12, atol=1e-13):
    """y(K) of the exact map's trajectory on ``n`` uniform K samples in [0, K_f]: (K, y).

    The switches of pass 1 (at the shooting tolerances) fix δ on each arc; one integration over
    [0, K_f] then reads δ by the switch count below K and steps exactly to every switch
    (diffrax ``jump_ts``), so no step straddles a discontinuity of the field."""
    tau = datum(tau)
    p1 = _pass1(sh, z, tau, prm, sh.rtol, sh.atol, sh.max_steps)
    Ks, ys, ok = _dense_over_arcs(sh, z, tau, prm, p1["d0"], p1["Ks"], n, padded_samples(n), max_steps, rtol, atol)
    require_success(ok, "dense output", max_steps)
    return Ks[:n], ys[:n]


@partial(jax.jit, static_argnums=(0, 7))
def _dense_over_arcs(sh, z, tau, prm, d0, Ks_switch, n, n_pad, max_steps, rtol, atol):
    """:func:`dense`'s integration over the arcs of pass 1 (δ = d0 before the first switch), on n
    samples padded to n_pad (:func:`.flow.padded_samples`)."""
    kf = sh.kf_index
    y0 = initial_state(sh, z, params_at(sh.model, prm, tau))
    Ks = uniform_samples(z[kf], n, n_pad)

    def rhs(K, y, _):
        odd = jnp.searchsorted(Ks_switch, K, side="right") % 2 == 1
        return field(sh.model, K, y, tau, prm, delta=jnp.where(odd, 1.0 - d0, d0))

    controller = diffrax.ClipStepSizeController(diffrax.PIDController(rtol=rtol, atol=atol), jump_ts=Ks_switch)
    out = diffrax.diffeqsolve(diffrax.ODETerm(rhs), diffrax.Dopri8(), 0.0, z[kf], None, y0,
                              stepsize_controller=capped(controller, max_steps), saveat=diffrax.SaveAt(ts=Ks),
                              max_steps=STEP_BOUND, throw=False)
    return Ks, out.ys, out.result == diffrax.RESULTS.successful
