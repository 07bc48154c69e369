"""Shooting maps f(z, τ) with fixed angular range and free time, and their exact Jacobians.

Boundary conditions (spec 01-methods §1.4, §2.1, §2.3, §2.4):

    K = 0:   x(0) = x₀, L_K(0) = L₀, t(0) = 0, m(0) = 1,         p_LK(0) + H(0) = 0,
    K = K_f: x(K_f) = x_f, L_K(K_f) + K_f = L_f, [p_m(K_f) = 0], [p_T(K_f)/τ = 0].

Unknowns z = (p_p, p_ex, p_ey, p_ix, p_iy, p_LK, [p_m], K_f, [T]):

| problem | unknowns | residuals | equations |
|---|---|---|---|
| LP    | 7 | p_LK+H, 5 elements, L_f          | (2.2.10)–(2.2.11) |
| OT    | 8 | + p_m(K_f)                       | (2.1.11)–(2.1.12) |
| T_min | 9 | + p_m(K_f), Q(K_f) = p_T(K_f)/τ   | (2.3.10)          |

Unperturbed, time-independent problems have p_t ≡ 0 and do not carry it; perturbed problems add
p_t(0) to the unknowns and p_t(K_f) = 0 to the residuals (time is free, §2.1). With a fixed
transfer time (1.1.11) p_t(0) is an unknown and t(K_f) = t_f replaces p_t(K_f) = 0. p_LK(0) is kept as an
unknown rather than eliminated by the quadratic (2.1.13), which is invalid with smoothed δ.

∂f/∂z and ∂f/∂τ come from the sensitivities Φ propagated with the trajectory; the K_f column is
g(K_f) (one extra field evaluation), as in the dissertation §3.3. No finite differences.
"""
from __future__ import annotations

from dataclasses import dataclass, field as dc_field
from functools import partial

import jax
import jax.numpy as jnp

from ..config import threads
from . import column_threads, hamiltonians as hm
from .flow import (Model, field, hamiltonian, has_bang_bang_throttle, params_at, propagate,
                   propagate_with_sensitivities, tmin_ot_tau)
from .transfer import MAX_STEPS, PATH_RTOL, SWITCHINGS, datum

COSTATE_NAMES = ("p_p", "p_ex", "p_ey", "p_ix", "p_iy", "p_LK", "p_t", "p_m")


@dataclass(frozen=True)
class Shooting:
    """Static layout of one shooting problem (hashable: it keys the JIT cache)."""
    model: Model
    free_costates: tuple          # indices into λ that are unknowns
    rtol: float = dc_field(default=1e-11, compare=False)   # end-point tolerances; passed to
    atol: float = dc_field(default=1e-12, compare=False)   # shoot() as traced values (no recompile)
    max_steps: int = dc_field(default=MAX_STEPS, compare=False)   # step cap, traced too (.flow.StepCap)
    path_rtol: float = dc_field(default=PATH_RTOL, compare=False)   # rtol while a path is followed
    fixed_time: bool = False      # t(K_f) = t_f (1.1.11) replaces p_t(K_f) = 0; p_t is then an unknown
    path_arcs: int = dc_field(default=1, compare=False)    # > 1: paths followed by multiple
    # shooting over that many arcs (chain._run, multiple_shooting); end points by single shooting
    switching: str = "smoothed"   # 'exact': δ = 1[S > 0] with switches located (.exact_switching)
    # the exact map's sensitivities (pass 2) at max(rtol, sensitivity_rtol): Newton needs the
    # Jacobian to ‖J⁻¹ δJ‖ ≪ 1, not to the residual's accuracy; None = the residual's tolerance.
    # The smoothed map integrates f and Φ in one solve and ignores it (.exact_switching.shoot)
    sensitivity_rtol: float | None = dc_field(default=None, compare=False)
    # a path's propagations capped at this factor times the steps of the path's last successful
    # Jacobian evaluation (chain.PathStepBudget); None = the step cap max_steps alone
    path_step_budget: float | None = dc_field(default=None, compare=False)

    def __post_init__(self):
        if self.switching not in SWITCHINGS:
            raise ValueError(f"switching: {self.switching!r} is neither 'smoothed' nor 'exact'")
        if self.switching == "exact" and not has_bang_bang_throttle(self.model):
            raise ValueError(f"switching: 'exact' needs a pure OT model, not {self.model}")
        if self.switching == "exact" and self.path_arcs > 1:
            raise ValueError(f"switching: 'exact' is single shooting (path_arcs {self.path_arcs})")

    @property
    def has_thrust(self) -> bool:
        return self.model.kind == "tmin"

    @property
    def kf_index(self) -> int:
        return len(self.free_costates)

    @property
    def size(self) -> int:
        return len(self.free_costates) + 1 + (1 if self.has_thrust else 0)

    def unknown_names(self):
        names = [COSTATE_NAMES[i] for i in self.free_costates] + ["K_f"]
        return names + (["T"] if self.has_thrust else [])

    def residual_names(self):
        names = ["p_LK+H", "p", "e_x", "e_y", "i_x", "i_y", "L_f"]
        if hm.MASS in self.free_costates:
            names.append("p_m(K_f)")
        if hm.TIME in self.free_costates:
            names.append("t(K_f)-t_f" if self.fixed_time else "p_t(K_f)")
        if self.has_thrust:
            names.append("p_T(K_f)/tau")
        return names


def initial_state(sh: Shooting, z, prm):
    """y(0) from the unknowns: states fixed by the left boundary, costates from z."""
    n = sh.model.n
    x = jnp.concatenate([prm["x0"], jnp.stack([prm["L0"], 0.0, 1.0])])
    if sh.has_thrust:
        x = jnp.concatenate([x, z[sh.kf_index + 1:sh.kf_index + 2]])
    lam = jnp.zeros(n).at[jnp.array(sh.free_costates)].set(z[:sh.kf_index])
    return jnp.concatenate([x, lam])


def terminal_residual(sh: Shooting, yf, Kf, prm, tau=1.0):
    n = sh.model.n
    r = [yf[:5] - prm["xf"], jnp.atleast_1d(yf[hm.LK] + Kf - prm["Lf"])]
    if hm.MASS in sh.free_costates:
        r.append(jnp.atleast_1d(yf[n + hm.MASS]))
    if hm.TIME in sh.free_costates:
        r.append(jnp.atleast_1d(yf[hm.TIME] - prm["tf"] if sh.fixed_time else yf[n + hm.TIME]))
    if sh.has_thrust and sh.model.homotopy in ("ot", "model"):     # T_min → OT: p_T(K_f) = 0 → T = T_OT
        t_ot = tmin_ot_tau(sh.model, tau, prm)
        r.append(jnp.atleast_1d((1.0 - t_ot) * yf[n + hm.THRUST] + t_ot * (yf[hm.THRUST] - prm["thrust"])))
    elif sh.has_thrust:
        r.append(jnp.atleast_1d(yf[n + hm.THRUST]))
    return jnp.concatenate(r)


def transversality(sh: Shooting, z, tau, prm):
    y0 = initial_state(sh, z, params_at(sh.model, prm, tau))
    return y0[sh.model.n + hm.LK] + hamiltonian(sh.model, 0.0, y0, tau, prm)


def shoot(sh: Shooting, z, tau, prm, rtol=None, atol=None):
    """Residual f(z, τ), ∂f/∂z, ∂f/∂τ, number of integration steps, success flag.

    ``rtol``/``atol`` default to the Shooting's end-point tolerances; they are traced, so the
    loose path tolerance and the tight end-point tolerance share one compiled function. With
    ``SPACEOPT_THREADS`` k > 1 the columns of Φ are propagated in k threads (.column_threads),
    except under a JAX transformation (``jax.jit(jax.vmap(shoot))``: one computation).
    τ is taken as a :func:`~.transfer.datum`: a path in arclength gives it as a NumPy scalar, a
    polish as a Python float, and the two types compiled each program twice.
    """
    tau = datum(tau)
    rtol, atol = sh.rtol if rtol is None else rtol, sh.atol if atol is None else atol
    tols = (rtol, atol, *sensitivity_tolerances(sh, rtol, atol)) if sh.switching == "exact" else (rtol, atol)
    k = threads()
    if k > 1 and not isinstance(z, jax.core.Tracer):
        return _map(sh, "shoot_threaded")(sh, z, tau, prm, *tols, k)
    return _map(sh, "shoot")(sh, z, tau, prm, *tols)


def sensitivity_tolerances(sh: Shooting, rtol, atol) -> tuple:
    """(rtol, atol) of the exact map's sensitivities at the residual's (rtol, atol):
    ``sh.sensitivity_rtol`` where it is looser, atol scaled with it."""
    if sh.sensitivity_rtol is None or sh.sensitivity_rtol <= rtol:
        return rtol, atol
    return sh.sensitivity_rtol, atol * sh.sensitivity_rtol / rtol


def _map(sh: Shooting, name: str):
    """The smoothed map's function ``name`` (this module), or the exact map's (.exact_switching)."""
    if sh.switching == "exact":
        from . import exact_switching
        return getattr(exact_switching, name)
    return {"shoot": _shoot, "shoot_threaded": _shoot_threaded, "residual": _residual,
            "final_state": _final_state}[name]


def residual(sh: Shooting, z, tau, prm, rtol=None, atol=None):
    """f(z, τ) of :func:`shoot` without its derivatives (residual, success flag)."""
    return _map(sh, "residual")(sh, z, datum(tau), prm, sh.rtol if rtol is None else rtol,
                                sh.atol if atol is None else atol)


def final_state(sh: Shooting, z, tau, prm):
    """y(K_f) from the unknowns z at the end-point tolerances, and the success flag."""
    return _map(sh, "final_state")(sh, z, datum(tau), prm, sh.rtol, sh.atol)


def _final_state(sh: Shooting, z, tau, prm, rtol, atol):
    return _final_state_capped(sh, z, tau, prm, rtol, atol, sh.max_steps)


@partial(jax.jit, static_argnums=0)
def _final_state_capped(sh: Shooting, z, tau, prm, rtol, atol, max_steps):
    y0 = initial_state(sh, z, params_at(sh.model, prm, tau))
    yf, _, ok = propagate(sh.model, y0, z[sh.kf_index], tau, prm, rtol, atol, max_steps)
    return yf, ok


def _residual(sh: Shooting, z, tau, prm, rtol, atol):
    """f from y(K_f): the propagation is :func:`_final_state`'s compiled program, not a copy."""
    yf, ok = _final_state(sh, z, tau, prm, rtol, atol)
    return _residual_at(sh, z, tau, prm, yf), ok


@partial(jax.jit, static_argnums=0)
def _residual_at(sh: Shooting, z, tau, prm, yf):
    r_term = terminal_residual(sh, yf, z[sh.kf_index], params_at(sh.model, prm, tau), tau)
    return jnp.concatenate([jnp.atleast_1d(transversality(sh, z, tau, prm)), r_term])


def start_with_sensitivities(sh: Shooting, z, tau, prm):
    """y(0) and its derivatives ∂y(0)/∂(z without K_f) (columns in the order of z) and ∂y(0)/∂τ."""
    kf = sh.kf_index

    def y0_of(znk, t):
        return initial_state(sh, jnp.insert(znk, kf, z[kf]), params_at(sh.model, prm, t))

    z_nokf = jnp.delete(z, kf, assume_unique_indices=True)
    return (y0_of(z_nokf, tau), *jax.jacfwd(y0_of, argnums=(0, 1))(z_nokf, tau))


def terminal_with_derivatives(sh: Shooting, yf, Kf, tau, prm):
    """The terminal residual at y(K_f) and its derivatives in y(K_f), K_f and τ."""
    def term(yy, kk, t):
        return terminal_residual(sh, yy, kk, params_at(sh.model, prm, t), t)
    return (term(yf, Kf, tau), *jax.jacfwd(term, argnums=(0, 1, 2))(yf, Kf, tau))


def transversality_with_derivatives(sh: Shooting, z, tau, prm):
    """p_LK(0) + H(0) and its derivatives in z and τ."""
    def r0(zz, tt):
        return transversality(sh, zz, tt, prm)
    return (r0(z, tau), *jax.jacfwd(r0, argnums=(0, 1))(z, tau))


def _start(sh: Shooting, z, tau, prm):
    """y(0) and Φ(0) = ∂y(0)/∂(z without K_f, τ), the τ column last."""
    y0, dy0_dz, dy0_dtau = start_with_sensitivities(sh, z, tau, prm)
    return y0, jnp.concatenate([dy0_dz, dy0_dtau[:, None]], axis=1)


def _assemble(sh: Shooting, z, tau, prm, yf, Phif):
    """f(z, τ), ∂f/∂z, ∂f/∂τ from y(K_f) and Φ(K_f)."""
    kf = sh.kf_index
    gf = field(sh.model, z[kf], yf, tau, prm)

    r_term, dr_dy, dr_dK, dr_dtau = terminal_with_derivatives(sh, yf, z[kf], tau, prm)
    dyf_dz = jnp.insert(Phif[:, :-1], kf, gf, axis=1)
    J_term = dr_dy @ dyf_dz
    J_term = J_term.at[:, kf].add(dr_dK)
    ftau_term = dr_dy @ Phif[:, -1] + dr_dtau

    r0, dr0_dz, dr0_dtau = transversality_with_derivatives(sh, z, tau, prm)

    f = jnp.concatenate([jnp.atleast_1d(r0), r_term])
    J = jnp.concatenate([dr0_dz[None, :], J_term], axis=0)
    ftau = jnp.concatenate([jnp.atleast_1d(dr0_dtau), ftau_term])
    return f, J, ftau


def _shoot(sh: Shooting, z, tau, prm, rtol, atol):
    return _shoot_capped(sh, z, tau, prm, rtol, atol, sh.max_steps)


@partial(jax.jit, static_argnums=0)
def _shoot_capped(sh: Shooting, z, tau, prm, rtol, atol, max_steps):
    y0, Phi0 = _start(sh, z, tau, prm)
    yf, Phif, nsteps, ok = propagate_with_sensitivities(
        sh.model, y0, Phi0, z[sh.kf_index], tau, prm, rtol, atol, max_steps)
    return (*_assemble(sh, z, tau, prm, yf, Phif), nsteps, ok)


_start_jit = jax.jit(_start, static_argnums=0)
_assemble_jit = jax.jit(_assemble, static_argnums=0)
_propagate_block = jax.jit(propagate_with_sensitivities, static_argnums=0)


def _shoot_threaded(sh: Shooting, z, tau, prm, rtol, atol, k):
    """:func:`_shoot` with the columns of Φ split over ``k`` threads (.column_threads)."""
    y0, Phi0 = _start_jit(sh, z, tau, prm)
    yf, Phif, nsteps, ok = column_threads.propagate(
        lambda Phi, tangent: _propagate_block(sh.model, y0, Phi, z[sh.kf_index], tau, prm, rtol, atol,
                                              sh.max_steps, 0.0, tangent), Phi0, k)
    return (*_assemble_jit(sh, z, tau, prm, yf, Phif), nsteps, ok)
