"""Multiple shooting: the single-shooting map of :mod:`.shooting` split into M arcs in K.

Over hundreds of revolutions the end state depends on the initial costates through a product
of hundreds of revolution maps (E8, 450 revolutions: cond ∂f/∂z = 4e7). Multiple shooting
(the dissertation shoots over one arc, spec 01-methods §3.1; this is the textbook remedy,
Stoer & Bulirsch §7.3.5) cuts the range at fixed nodes 0 < K₁ < … < K_{M−1} < K_f and adds the
full state-costate vector y_j at every inner node to the unknowns:

    Z = (z, w₁ ⊙ y₁, …, w_{M−1} ⊙ y_{M−1}),   z = the single-shooting unknowns (costates at K = 0, K_f),

    F(Z, τ) = ( p_LK(0) + H(0),
                w₁ ⊙ (y(K₁; y(0; z)) − y₁), …, w_{M−1} ⊙ (y(K_{M−1}; y_{M−2}) − y_{M−1}),
                terminal residual of y(K_f; y_{M−1}) ),

each arc integrated from its own node, so each sensitivity matrix spans only K_f/M. Rows and
node unknowns are scaled by fixed weights w_j = 1/max(1, |y_j|) of the starting nodes (t grows
to ~2000 time units over E8: its continuity is measured relatively, and the arclength of a
path in Z is not dominated by the node times; Newton's steps do not depend on the scaling).
The nodes stay fixed while K_f moves (the last arc ends at K_f); the K_f column is g(K_f) of
the last arc, as in single shooting. At τ = 1 the first block of Z is a single-shooting
solution: the same extremal, returned in the single-shooting layout so that everything
downstream is unchanged. Measured on E8's lunisolar blend at 450–500 revolutions (10 arcs):
1.5–3× longer continuation steps than single shooting, but Newton's basin stays small there
(docs/perturbed-e6-e7-e8.md, "seventh session").

Sensitivities: every arc carries Φ with 2n + 1 columns (∂/∂y_j and the τ column; the first arc
∂/∂(free costates) padded with zeros), so all arcs are one ``jax.vmap`` of the single-arc
propagator (:func:`.flow.propagate_with_sensitivities`).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import diffrax
import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ConvergenceError
from .flow import STEP_BOUND, capped, field, params_at, propagate, propagate_with_sensitivities
from .shooting import (Shooting, initial_state, start_with_sensitivities, terminal_residual,
                       terminal_with_derivatives, transversality, transversality_with_derivatives)
from .transfer import datum


@dataclass(frozen=True)
class MultipleShooting:
    """Static layout: the single-shooting problem and the number of arcs (≥ 2)."""
    single: Shooting
    arcs: int

    def __post_init__(self):
        if self.arcs < 2:
            raise ValueError(f"multiple shooting needs at least 2 arcs, got {self.arcs}")

    @property
    def width(self) -> int:
        """2n: the length of one node vector y_j."""
        return 2 * self.single.model.n

    @property
    def size(self) -> int:
        return self.single.size + (self.arcs - 1) * self.width


def node_positions(K_f: float, arcs: int) -> np.ndarray:
    """The inner nodes K_j = j K_f / M, j = 1 … M−1 (fixed once chosen)."""
    return np.arange(1, arcs) * (K_f / arcs)


def start_nodes(ms: MultipleShooting, z, tau, prm, nodes):
    """Z from a single-shooting point z: the scaled y at the nodes of the trajectory through z at
    τ, and the weights 1/max(1, |y_j|)."""
    sh = ms.single
    y0 = initial_state(sh, jnp.asarray(z), params_at(sh.model, prm, tau))
    ys, ok = _through_nodes(sh.model, y0, jnp.asarray(nodes), tau, prm, sh.rtol, sh.atol, sh.max_steps)
    if not bool(ok):
        raise ConvergenceError("multiple shooting: the trajectory through the starting point does not "
                               f"reach the last node (K = {float(nodes[-1]):.6g})", {"z": np.asarray(z).tolist()})
    ys = np.asarray(ys)
    weights = 1.0 / np.maximum(1.0, np.abs(ys))
    return np.concatenate([np.asarray(z, float), (weights * ys).ravel()]), weights


@partial(jax.jit, static_argnums=0)
def _through_nodes(model, y0, nodes, tau, prm, rtol, atol, max_steps):
    out = diffrax.diffeqsolve(
        diffrax.ODETerm(lambda K, y, args: field(model, K, y, tau, args)), diffrax.Dopri8(),
        0.0, nodes[-1], None, y0, args=prm,
        stepsize_controller=capped(diffrax.PIDController(rtol=rtol, atol=atol), max_steps),
        saveat=diffrax.SaveAt(ts=nodes), max_steps=STEP_BOUND, throw=False)
    return out.ys, out.result == diffrax.RESULTS.successful


def shoot(ms: MultipleShooting, Z, tau, prm, nodes, weights, rtol=None, atol=None):
    """F(Z, τ), ∂F/∂Z, ∂F/∂τ, integration steps (all arcs), success flag (τ a datum, as in
    :func:`.shooting.shoot`)."""
    sh = ms.single
    return _shoot(ms, Z, datum(tau), prm, nodes, weights, sh.rtol if rtol is None else rtol,
                  sh.atol if atol is None else atol, sh.max_steps)


def residual(ms: MultipleShooting, Z, tau, prm, nodes, weights, rtol=None, atol=None):
    """F(Z, τ) of :func:`shoot` without its derivatives (residual, success flag)."""
    sh = ms.single
    return _residual(ms, Z, datum(tau), prm, nodes, weights, sh.rtol if rtol is None else rtol,
                     sh.atol if atol is None else atol, sh.max_steps)


def _unpack(ms: MultipleShooting, Z, nodes, weights):
    """z, K_f, the node states y_j (unscaled) and each arc's (K_start, K_end)."""
    sh = ms.single
    z, Kf = Z[:sh.size], Z[sh.kf_index]
    ys = Z[sh.size:].reshape(ms.arcs - 1, ms.width) / weights
    return z, Kf, ys, jnp.concatenate([jnp.zeros(1), nodes]), jnp.concatenate([nodes, Kf[None]])


@partial(jax.jit, static_argnums=0)
def _residual(ms: MultipleShooting, Z, tau, prm, nodes, weights, rtol, atol, max_steps):
    sh = ms.single
    z, Kf, ys, K0, K1 = _unpack(ms, Z, nodes, weights)
    Y0 = jnp.concatenate([initial_state(sh, z, params_at(sh.model, prm, tau))[None], ys])
    yend, _, ok = jax.vmap(lambda y, a, b: propagate(sh.model, y, b, tau, prm, rtol, atol, max_steps, K0=a))(Y0, K0, K1)
    r_term = terminal_residual(sh, yend[-1], Kf, params_at(sh.model, prm, tau), tau)
    cont = (weights * (yend[:-1] - ys)).ravel()
    return jnp.concatenate([jnp.atleast_1d(transversality(sh, z, tau, prm)), cont, r_term]), jnp.all(ok)


@partial(jax.jit, static_argnums=0)
def _shoot(ms: MultipleShooting, Z, tau, prm, nodes, weights, rtol, atol, max_steps):
    sh, M, w = ms.single, ms.arcs, ms.width
    s, kf = sh.size, sh.kf_index
    z, Kf, ys, K0, K1 = _unpack(ms, Z, nodes, weights)

    y0, dy0_dz, dy0_dtau = start_with_sensitivities(sh, z, tau, prm)
    first = jnp.zeros((w, w + 1)).at[:, :s - 1].set(dy0_dz).at[:, -1].set(dy0_dtau)
    inner = jnp.broadcast_to(jnp.eye(w, w + 1), (M - 1, w, w + 1))
    Y0 = jnp.concatenate([y0[None], ys])
    Phi0 = jnp.concatenate([first[None], inner])
    prop = jax.vmap(lambda y, P, a, b: propagate_with_sensitivities(
        sh.model, y, P, b, tau, prm, rtol, atol, max_steps, K0=a))
    yend, Phi, nsteps, ok = prop(Y0, Phi0, K0, K1)

    # continuity rows: arc j = 0 … M−2 ends at node j+1 (columns: the first arc's free unknowns
    # are z without K_f; arc j ≥ 1 starts at y_j; every row block has −w_j at y_{j+1})
    n_cont = (M - 1) * w
    free = np.array([i for i in range(s) if i != kf])
    J_cont = jnp.zeros((n_cont, ms.size)).at[:w, free].set(Phi[0][:, :s - 1])
    for j in range(1, M - 1):
        J_cont = J_cont.at[j * w:(j + 1) * w, s + (j - 1) * w:s + j * w].set(Phi[j][:, :w])
    J_cont = weights.reshape(-1, 1) * J_cont
    J_cont = J_cont.at[:, s:].divide(weights.ravel())          # columns: the scaled node unknowns
    J_cont = J_cont.at[:, s:].add(-jnp.eye(n_cont))            # ∂/∂(w ⊙ y_{j+1}) of −w ⊙ y_{j+1}
    cont = (weights * (yend[:-1] - ys)).ravel()
    cont_tau = (weights * Phi[:-1, :, -1]).ravel()

    # terminal rows from the last arc
    yf = yend[-1]
    r_term, dr_dy, dr_dK, dr_dtau = terminal_with_derivatives(sh, yf, Kf, tau, prm)
    gf = field(sh.model, Kf, yf, tau, prm)
    J_term = jnp.zeros((r_term.shape[0], ms.size))
    J_term = J_term.at[:, s + (M - 2) * w:].set(dr_dy @ Phi[-1][:, :w] / weights[-1])
    J_term = J_term.at[:, kf].add(dr_dy @ gf + dr_dK)
    f_term_tau = dr_dy @ Phi[-1][:, -1] + dr_dtau

    r0, dr0_dz, dr0_dtau = transversality_with_derivatives(sh, z, tau, prm)
    J0 = jnp.zeros(ms.size).at[:s].set(dr0_dz)

    f = jnp.concatenate([jnp.atleast_1d(r0), cont, r_term])
    J = jnp.concatenate([J0[None], J_cont, J_term])
    ftau = jnp.concatenate([jnp.atleast_1d(dr0_dtau), cont_tau, f_term_tau])
    return f, J, ftau, jnp.sum(nsteps), jnp.all(ok)
