"""Canonical fields derived by JAX, the homotopy blends, and their propagation with sensitivities.

Hamiltonian field (2.1.10):  dx/dK = ∂H/∂λ,  dλ/dK = −∂H/∂x,  built with ``jax.grad``.

Homotopy fields (3.3.1) LP→OT and (3.4.1) LP→T_min, written as the blend the printed equations
reduce to once their typos are fixed (spec 01-methods §3.3, "clean interpretation"):

    g_τ = [(1 − τ) g_LP' + τ W g_target] / (1 − τ + τ W),

with g_LP' the field of ½ k|A|², W = |A| (OT) or |A₁| (T_min). The printed (3.4.1) uses the
blended primer B = (1−τ)A + τA₁ in its state rows; we use the same blend for every row of both
homotopies — the end points τ = 0 and τ = 1 are identical, which is all the method requires.
W is measured in units of W_ref (``prm['blend_ref']``, the mean LP primer magnitude): with the
printed weights, a 100-revolution problem whose primer is ~10⁻³ only leaves the LP field in the
last 0.1 % of τ, and the continuation crawls there; scaling W reparametrises τ without moving
either end point (measured: see benchmarks/multirev.py). Where the OT thrust is far above the
LP's, W_ref may also carry the ratio of the two (``chain.blend_reference``, E9).

Smoothed throttle: δ(S(y), ε) is evaluated outside ``jax.grad`` and passed to H as a constant, so
the costate equations carry no ∂δ/∂S term (δ frozen, spec 01-methods §7), while ``jax.jvp`` of
the whole field — the sensitivity equations — does see dδ/dy.

Sensitivities (3.1.5–3.1.6): Φ = ∂y/∂(z, τ) obeys dΦ/dK = g_y Φ (+ g_τ in the τ column); the
directional derivatives are ``jax.jvp`` of the field, one tangent per column under ``jax.vmap``
(:func:`field_with_tangents`).
Integration: diffrax Dopri8 (8(7) Dormand–Prince) with a PID step-size controller whose error
norm covers the state and costates (the sensitivities ride along on the same steps).

:func:`field` and :func:`hamiltonian` are ``jax.jit`` functions of a static model: JAX traces
them once per model and argument shapes in a process and reuses the jaxpr (and its jvp)
at every further call site, where a plain function is traced again at each one (diffrax alone
traces a vector field three times per solve). XLA inlines them, so the compiled programs and
their run time are unchanged; tracing an E1 J2 Jacobian program takes 2.7 s instead of 6.2 s, the
exact map's 5.0 s instead of 11.9 s (scratch, 29 Nov).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial

import diffrax
import jax
import jax.numpy as jnp

from ..errors import ConvergenceError
from . import hamiltonians as hm
from .transfer import STEP_BOUND


def hamiltonian_field(H, K, y, n):
    """J ∇H: (∂H/∂λ, −∂H/∂x) for y = (x, λ) with len(x) = n."""
    x, lam = y[:n], y[n:]
    dHdx, dHdl = jax.grad(H, argnums=(1, 2))(K, x, lam)
    return jnp.concatenate([dHdl, -dHdx])


@dataclass(frozen=True)
class Model:
    """Static description of a field: which problem and which homotopy parameter τ drives.

    kind: 'lp' (LP, τ unused — Newton homotopy), 'ot' or 'tmin'.
    homotopy (for 'ot'): 'lp' — τ blends LP→OT and ε(τ) = 1 − τ + ε₁ τ (3.3.1);
                         'eps' — pure OT with ε = ε₁^(1−τ) ε_f^τ (log-uniform smoothing).
    homotopy (for 'tmin'): 'lp' — τ blends LP→T_min (3.4.1);
                           'ot' — τ carries T_min → OT (:func:`hamiltonians.h_tmin_ot`): the
                           propellant weight grows from 0 to 1, δ = 1 − τ + τ δ(S, ε₁), and the
                           thrust residual moves from p_T(K_f) = 0 to T = T_OT (shooting).
    homotopy 'pert' (for 'ot'): the pure OT problem at ε_f with the perturbations scaled by τ
        (unperturbed → perturbed solution, the perturbation switch of (3.3.1) on its own).
    homotopy 'model' (for 'ot'): the pure OT problem at ε_f with the perturbing acceleration
        blended from the force model ``prm['pert_from']`` to ``prm['pert']``,
        a_p = (1 − τ) a_p,from + τ a_p,to (H_p is linear in a_p): a change of force model along
        the physical path (E8: J2 → 4×4 + Moon + Sun).
    homotopy 'model' (for 'tmin'): the T_min → OT problem at a fixed point τ_ot =
        ``prm['tau_ot']`` of its homotopy, with the force model blended as for 'ot' (an upper bound
        on T_min moved to another force model, :func:`.tmin_from_ot.bound_in_model`).
    homotopy 'param' (any kind): the pure problem with problem data moved linearly from
        ``prm['path_from']`` to ``prm['path_to']`` (thrust, L0, L_f, …) — warm starts along a
        sweep or a thrust family.
    perturbed: add H_p = k1 k2 (A·a_p) — switched on by τ in the blends (τ g_pert, (3.3.1) and
    (3.4.1)), fully present in the pure problems; t is then a true state and p_t an unknown.
    """
    kind: str
    homotopy: str = "lp"
    perturbed: bool = False

    @property
    def n(self) -> int:
        return hm.N_STATE + (1 if self.kind == "tmin" else 0)


def _lp_prime(prm):
    return {**prm, "lp_scale": 0.5}


def params_at(model: Model, prm, tau):
    """Problem data at τ: moved along the path for the 'param' homotopy, unchanged otherwise."""
    if model.homotopy != "param":
        return prm
    frm, to = prm["path_from"], prm["path_to"]
    return {**prm, **{k: frm[k] + tau * (to[k] - frm[k]) for k in frm}}


def ot_params(model: Model, tau, prm):
    """Thrust and ε at τ for an OT model."""
    if model.homotopy == "eps":
        return prm["thrust"], prm["eps_blend"] ** (1.0 - tau) * prm["eps_final"] ** tau
    if model.homotopy == "lp":
        return prm["thrust"], hm.epsilon_schedule(tau, prm["eps_blend"])
    return prm["thrust"], prm["eps_final"]


def ot_delta(model: Model, K, y, tau, prm):
    n = model.n
    thrust, eps = ot_params(model, tau, prm)
    prm_t = {**prm, "thrust": thrust}
    S = hm.switching_ot(K, y[:n], y[n:], prm_t)
    return hm.smooth_delta(S, eps), S, prm_t


def tmin_ot_tau(model: Model, tau, prm):
    """τ of the T_min → OT homotopy (:func:`hamiltonians.h_tmin_ot`): the path parameter of
    ('tmin', 'ot'); ``prm['tau_ot']``, held fixed, in ('tmin', 'model'), whose τ blends the force model."""
    return prm["tau_ot"] if model.homotopy == "model" else tau


def _pert_shift(model, y, tau, prm):
    if model.kind != "tmin":
        return 0.0
    tmin_ot = model.homotopy in ("ot", "model")
    return -(1.0 - tmin_ot_tau(model, tau, prm) if tmin_ot else 1.0) * 0.5 * y[hm.THRUST] ** 2


def tmin_ot_delta(K, y, tau, prm):
    """Throttle of the T_min → OT homotopy: 1 − τ + τ δ(S, ε₁) (always on at τ = 0)."""
    n = hm.N_STATE + 1
    S = hm.switching_tmin_ot(K, y[:n], y[n:], prm, tau)
    return 1.0 - tau + tau * hm.smooth_delta(S, prm["eps_blend"]), S


def model_blend_params(prm_to: dict, pert_from) -> dict:
    """The data of the force-model blend (homotopy 'model') from ``pert_from`` to
    ``prm_to['pert']``: the terms the two models share are evaluated once, so their data must
    agree (:func:`spaceopt.forces.check_blend`, ValueError otherwise)."""
    from ..forces import check_blend
    check_blend(pert_from, prm_to["pert"])
    return {**prm_to, "pert_from": pert_from}


def _pert_weight(model, tau):
    """τ in the LP→target blends and the perturbation homotopy 'pert', 1 in the pure problems."""
    return tau if (model.kind != "lp" and model.homotopy in ("lp", "pert")) else 1.0


def _h_perturbation(model: Model, K, x, lam, tau, prm, shift):
    """The perturbation term of H at τ: τ-weighted H_p; in the model blend 'model',
    τ H_p[to] + (1 − τ) H_p[from] = H_p of the blended acceleration (H_p is linear in a_p), the
    orbital frame computed once (:func:`hamiltonians.perturbation_tnr`)."""
    if model.homotopy == "model":
        return hm.h_pert(K, x, lam, prm, shift, blend=tau)
    return _pert_weight(model, tau) * hm.h_pert(K, x, lam, prm, shift)


@partial(jax.jit, static_argnums=0)
def field(model: Model, K, y, tau, prm, delta=None):
    """dy/dK of ``model`` at homotopy parameter τ (perturbation field added when perturbed).

    ``delta`` fixes the throttle of a pure OT field (0 or 1 on an arc of the exact bang-bang map,
    :mod:`.exact_switching`) instead of the smoothed δ(S, ε)."""
    prm = params_at(model, prm, tau)
    g = _unperturbed_field(model, K, y, tau, prm, delta)
    if model.perturbed:
        shift = _pert_shift(model, y, tau, prm)
        g = g + hamiltonian_field(
            lambda K_, x_, l_: _h_perturbation(model, K_, x_, l_, tau, prm, shift), K, y, model.n)
    return g


def has_bang_bang_throttle(model: Model) -> bool:
    """Whether ``model``'s throttle is a function of S alone, so that it can be fixed on the arcs
    of the exact map: a pure OT field (the LP → OT blend and the T_min problems are not)."""
    return model.kind == "ot" and model.homotopy != "lp"


def _ot_throttle(model: Model, K, y, tau, prm, delta):
    """(δ, problem data at the OT thrust): the smoothed δ(S, ε), or ``delta`` where it is given."""
    if delta is None:
        delta, _, prm_t = ot_delta(model, K, y, tau, prm)
        return delta, prm_t
    if not has_bang_bang_throttle(model):
        raise ValueError(f"a fixed throttle needs a pure OT model, not {model}")
    return delta, {**prm, "thrust": ot_params(model, tau, prm)[0]}


def _unperturbed_field(model: Model, K, y, tau, prm, delta=None):
    n = model.n
    if model.kind == "lp":
        return hamiltonian_field(partial(hm.h_lp, prm={**prm, "lp_scale": 1.0}), K, y, n)
    if model.kind == "ot":
        delta, prm_t = _ot_throttle(model, K, y, tau, prm, delta)
        g_tgt = hamiltonian_field(partial(hm.h_ot, prm=prm_t, delta=delta), K, y, n)
        if model.homotopy != "lp":
            return g_tgt
        W = hm.primer_magnitude(K, y[:n], y[n:])
    elif model.kind == "tmin" and model.homotopy in ("ot", "model"):
        tau_ot = tmin_ot_tau(model, tau, prm)
        delta, _ = tmin_ot_delta(K, y, tau_ot, prm)
        return hamiltonian_field(lambda K_, x_, l_: hm.h_tmin_ot(K_, x_, l_, prm, tau_ot, delta), K, y, n)
    elif model.kind == "tmin":
        g_tgt = hamiltonian_field(partial(hm.h_tmin, prm=prm), K, y, n)
        if model.homotopy != "lp":
            return g_tgt
        W = hm.primer_magnitude(K, y[:n], y[n:], -0.5 * y[hm.THRUST] ** 2)
    else:
        raise ValueError(model.kind)
    g_lp = hamiltonian_field(partial(hm.h_lp, prm=_lp_prime(prm)), K, y, n)
    W = W / prm["blend_ref"]
    den = 1.0 - tau + tau * W
    g = ((1.0 - tau) * g_lp + tau * W * g_tgt) / den
    if model.kind == "tmin":
        # p_T enters no other equation, so p_T(K) = τ Q(K) exactly; we integrate Q, whose
        # terminal value is the T_min residual with the τ = 0 singularity of (3.4.1) removed.
        g = g.at[n + hm.THRUST].set(W * g_tgt[n + hm.THRUST] / den)
    return g


@partial(jax.jit, static_argnums=0)
def hamiltonian(model: Model, K, y, tau, prm, delta=None):
    """H entering the transversality residual p_LK(0) + H(0): (1−τ) H_LP' + τ H_target [+ τ H_p];
    ``delta`` as in :func:`field`."""
    prm = params_at(model, prm, tau)
    h = _unperturbed_hamiltonian(model, K, y, tau, prm, delta)
    if model.perturbed:
        n = model.n
        h = h + _h_perturbation(model, K, y[:n], y[n:], tau, prm, _pert_shift(model, y, tau, prm))
    return h


def _unperturbed_hamiltonian(model: Model, K, y, tau, prm, delta=None):
    n = model.n
    x, lam = y[:n], y[n:]
    if model.kind == "lp":
        return hm.h_lp(K, x, lam, {**prm, "lp_scale": 1.0})
    if model.kind == "ot":
        delta, prm_t = _ot_throttle(model, K, y, tau, prm, delta)
        h_t = hm.h_ot(K, x, lam, prm_t, delta)
    elif model.homotopy in ("ot", "model"):
        tau_ot = tmin_ot_tau(model, tau, prm)
        return hm.h_tmin_ot(K, x, lam, prm, tau_ot, tmin_ot_delta(K, y, tau_ot, prm)[0])
    else:
        h_t = hm.h_tmin(K, x, lam, prm)
    if model.homotopy != "lp":
        return h_t
    return (1.0 - tau) * hm.h_lp(K, x, lam, _lp_prime(prm)) + tau * h_t


def _primal_rms(err):
    y_err = err[0] if isinstance(err, tuple) else err
    return jnp.sqrt(jnp.mean(y_err**2))


# The step cap of a propagation is a traced value, not diffrax's static ``max_steps``: a static
# cap is a constant of the compiled program, so each cap compiled programs of its own (a study's
# step_cap and the default MAX_STEPS, each E8 revolution count), 10–20 s each with perturbations.
# diffrax's loop is bounded by STEP_BOUND (.transfer), and StepCap ends the solve after ``cap`` steps.


class _Wrapper(diffrax.AbstractAdaptiveStepSizeController):
    """An adaptive controller around ``inner``, whose tolerances, norm and step decisions it keeps."""
    inner: diffrax.AbstractAdaptiveStepSizeController

    @property
    def rtol(self):
        return self.inner.rtol

    @property
    def atol(self):
        return self.inner.atol

    @property
    def norm(self):
        return self.inner.norm

    def wrap(self, direction):
        return replace(self, inner=self.inner.wrap(direction))


class StepCap(_Wrapper):
    """An adaptive controller that ends a solve which cannot finish; every step decision is the
    ``inner`` controller's:

    - after ``cap`` steps, accepted and rejected (``RESULTS.max_steps_reached``), as diffrax's
      ``max_steps`` does, with ``cap`` a traced integer (diffrax has no dynamic step limit);
    - once it has stalled (``RESULTS.dt_min_reached``): the step just taken had zero length and
      so has the next one proposed. A step whose field is not finite (past the end of an
      ephemeris window, a degenerate orbit) is rejected and shrunk fivefold; at such a wall the
      step shrinks below one ulp of K, K + dK == K, the zero-length step is accepted (its error
      is zero), and the PID controller's multiplicative update keeps the step at zero for good.
      The solve then ran out its cap in zero-length steps (measured: 399 919 of them, minutes).
      One zero-length step alone is not a stall: by its code, diffrax's jump clipping
      (``ClipStepSizeController``) can cut one proposal to zero length where two jump times lie
      an ulp or two apart, and moves the next step past them.

    The compiled program is not the inner controller's, though: XLA contracts a·b + c into
    fused multiply-adds within its fusions, so a change to this loop body moves every solve at
    round-off (E1's OT unknowns by 1e-12 relative, measured)."""
    cap: jax.Array

    def init(self, terms, t0, t1, y0, dt0, args, func, error_order):
        t_next, state = self.inner.init(terms, t0, t1, y0, dt0, args, func, error_order)
        return t_next, (state, jnp.asarray(0, dtype=jnp.int32))

    def adapt_step_size(self, t0, t1, y0, y1_candidate, args, y_error, error_order, controller_state):
        state, steps = controller_state
        keep, t_prev, t_next, jump, state, result = self.inner.adapt_step_size(
            t0, t1, y0, y1_candidate, args, y_error, error_order, state)
        steps = steps + 1
        stalled = (t1 <= t0) & (t_next <= t_prev)
        result = diffrax.RESULTS.where(stalled, diffrax.RESULTS.dt_min_reached, result)
        result = diffrax.RESULTS.where(steps > self.cap, diffrax.RESULTS.max_steps_reached, result)
        return keep, t_prev, t_next, jump, (state, steps), result


class StepMemory(_Wrapper):
    """An adaptive controller that records the step the ``inner`` controller proposes after each
    step, accepted or rejected: its state is (inner state, the last proposal, the one before, so
    the size of the last step before t1 cut it short), read back with
    ``SaveAt(controller_state=True)``. Every step decision is the inner controller's, so the
    solution is the same to the bit. Written here because diffrax returns no step size with a
    solution; the exact map (:mod:`.exact_switching`) starts each piece of a solve it cuts at
    switches and segment ends from the step recorded in the piece before (``dt0``) instead of
    diffrax's initial-step rule, which costs two field evaluations and a first step one to three
    orders below the orbit's, grown at most tenfold a step."""

    def init(self, terms, t0, t1, y0, dt0, args, func, error_order):
        t_next, state = self.inner.init(terms, t0, t1, y0, dt0, args, func, error_order)
        first = jnp.asarray(t_next - t0)
        return t_next, (state, first, first)

    def adapt_step_size(self, t0, t1, y0, y1_candidate, args, y_error, error_order, controller_state):
        state, last, _ = controller_state
        keep, t_prev, t_next, jump, state, result = self.inner.adapt_step_size(
            t0, t1, y0, y1_candidate, args, y_error, error_order, state)
        return keep, t_prev, t_next, jump, (state, t_next - t_prev, last), result

    @staticmethod
    def proposals(controller_state):
        """(the last proposal, the one before) from a solve's saved state of this controller."""
        return controller_state[1], controller_state[2]


def capped(controller, max_steps):
    """``controller`` with the step cap ``max_steps`` (traced; at most STEP_BOUND)."""
    return StepCap(controller, jnp.asarray(max_steps, dtype=jnp.int32))


def primal_control(rtol, atol):
    """The PID controller of the shooting propagations: its error norm is that of y alone."""
    return diffrax.PIDController(rtol=rtol, atol=atol, norm=_primal_rms)


def step_control(rtol, atol, max_steps):
    """:func:`primal_control` with the step cap ``max_steps``."""
    return capped(primal_control(rtol, atol), max_steps)


def require_success(ok, what: str, max_steps) -> None:
    """Raise ConvergenceError where the re-propagation of a solution (dense output, integrals)
    failed. Those programs return diffrax's success flag (``throw=False``) instead of raising
    inside: diffrax's ``throw`` puts a Python callback in the program, and JAX writes no program
    with callbacks to its persistent compilation cache, so each process compiled it again. (The
    dense programs keep one callback: diffrax checks their traced save times ``SaveAt(ts)``.)"""
    if not bool(ok):
        raise ConvergenceError(f"{what}: the propagation failed (step cap {int(max_steps)} reached, or the step "
                               "shrank to zero at a non-finite field)",
                               {"reason": f"{what} propagation failed", "max_steps": int(max_steps)})


def _solve(rhs, y0, K0, Kf, args, rtol, atol, max_steps, saveat):
    return diffrax.diffeqsolve(
        diffrax.ODETerm(rhs), diffrax.Dopri8(), t0=K0, t1=Kf, dt0=None, y0=y0, args=args,
        stepsize_controller=step_control(rtol, atol, max_steps), saveat=saveat, max_steps=STEP_BOUND,
        throw=False)


def propagate(model: Model, y0, Kf, tau, prm, rtol, atol, max_steps, K0=0.0):
    """Integrate y alone from K = K0 to Kf: y(Kf), steps, success. The step control reads the
    primal error only, so y(Kf) is that of :func:`propagate_with_sensitivities` to the integration
    error, at a fraction of its cost (E8 450 rev over 10 arcs: 6 s against 2 min)."""
    sol = _solve(lambda K, y, args: field(model, K, y, *args), y0, K0, Kf, (tau, prm), rtol, atol,
                 max_steps, diffrax.SaveAt(t1=True))
    return sol.ys[-1], sol.stats["num_steps"], sol.result == diffrax.RESULTS.successful


def field_with_tangents(g, y, tau, Phi, tau_tangent):
    """g(y, τ) and its derivative along each column of Φ: g_y Φ + g_τ w (w = ``tau_tangent``).

    One ``jax.jvp`` per column under ``jax.vmap``: the primal does not depend on the batched
    tangents, so it stays unbatched and is computed once (``out_axes=None`` checks it). Tracing
    it takes less than half the time of ``jax.linearize`` followed by ``vmap`` of the linear map
    (E1 4×4 OT Jacobian program: 1.9–2.5 s against 4.9–6.4 s; same compiled size, scratch 29 Nov),
    and every test and Snakemake job traces its own programs."""
    return jax.vmap(lambda v, t: jax.jvp(g, (y, tau), (v, t)), in_axes=(1, 0), out_axes=(None, 1))(Phi, tau_tangent)


def propagate_with_sensitivities(model: Model, y0, Phi0, Kf, tau, prm, rtol, atol, max_steps, K0=0.0,
                                 tau_tangent=None):
    """Integrate y and Φ = ∂y/∂(z…, τ) from K = K0 to Kf. The last column of Φ is the τ column,
    or, with ``tau_tangent``, each column's weight of ∂/∂τ (a block of columns, .column_threads)."""
    if tau_tangent is None:
        tau_tangent = jnp.zeros(Phi0.shape[1]).at[-1].set(1.0)

    def rhs(K, Y, args):
        tau_, prm_ = args
        return field_with_tangents(lambda yy, tt: field(model, K, yy, tt, prm_), Y[0], tau_, Y[1], tau_tangent)

    sol = _solve(rhs, (y0, Phi0), K0, Kf, (tau, prm), rtol, atol, max_steps, diffrax.SaveAt(t1=True))
    yf, Phif = sol.ys[0][-1], sol.ys[1][-1]
    return yf, Phif, sol.stats["num_steps"], sol.result == diffrax.RESULTS.successful


# Dense output: the sample count is a static shape, so each count used to compile its own
# program (an artifact's samples, its re-sampled check at another count, each transfer's
# n_rev). The programs are compiled for a padded count instead and the grid is filled up with
# K_f (diffrax's SaveAt(ts) takes repeated times): one program serves every count up to
# DENSE_MIN_SAMPLES, and above it every count up to the next power of two.
DENSE_MIN_SAMPLES = 4096


def padded_samples(n: int) -> int:
    """The sample count a dense program is compiled for, ≥ n."""
    return max(DENSE_MIN_SAMPLES, 1 << (int(n) - 1).bit_length())


def uniform_samples(K_f, n, n_pad: int):
    """n uniform samples of [0, K_f] (n traced), then K_f up to the static length n_pad."""
    return K_f * (jnp.minimum(jnp.arange(n_pad), n - 1) / (n - 1))      # the last is K_f exactly
