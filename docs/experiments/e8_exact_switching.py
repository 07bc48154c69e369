"""E8 spike: the minimum-fuel shooting map with the exact bang-bang throttle (thirtieth session).

Why: at ε_f = 1e-5 the smoothed throttle δ(S, ε) (3.3.2) changes from 0 to 1 over |S| ≲ ε, and
Dopri8's error control resolves each of these steep transitions with many small steps. At E8 500
(unperturbed) the artifact's trajectory takes 56 541 steps at ε_f and 14 084 at ε = 0.1; three
quarters of the work of every end-point Jacobian goes into the switches.

What this does instead (ε → 0, the problem the smoothing approximates):

1. **Switches by events** (pass 1, primal only). Each arc is integrated with δ fixed (0 or 1)
   until (2δ − 1) S(K, y) < −1e-10 at a step end (a diffrax event without root finder). S is
   then sampled on the Dopri8 dense output (8th order) every ``GRID`` rad up to that step end, and
   the first sign change after a sample on the right side is located by bisection on the
   interpolant. The samples also catch an arc shorter than one step (S dipping across zero and
   back between two step ends), which the event cannot see. The state at the switch is then
   stepped from the last accepted step point before it (the dense output's own error, summed
   over a thousand switches, moved t(K_f) by 3e-5 TU at 500 revolutions). diffrax's own event root find
   (optimistix Newton on the interpolant) was tried first: at 500 revolutions it stopped at its
   iteration limit on a tenth of the arcs and returned times up to 6 rad off the crossing.
2. **Sensitivities with saltation** (pass 2). (y, Φ) are integrated arc by arc with δ fixed
   (Φ' = g_y Φ, δ frozen as in :mod:`spaceopt.indirect.flow`), and at each switch K_s
       dK_s/dz = −(∇_y S · Φ⁻) / (∂S/∂K + ∇_y S · g⁻),    Φ⁺ = Φ⁻ + (g⁻ − g⁺) dK_s/dz,
   the jump of the sensitivities where the field is discontinuous (the saltation matrix).
3. The shooting residual and Jacobian are assembled as in :func:`spaceopt.indirect.shooting._shoot`,
   with ε = 0 in the transversality condition and the K_f column (δ = 1[S > 0] there).

Written by hand because diffrax integrates one smooth field per solve; the arc loop and the
saltation are the standard treatment of a field discontinuous across a switching surface.

Subcommands (run from the project root, results/ holding the E8 artifacts):

    cost   MODEL N [GRID]   one Jacobian propagation: smoothed at ε_f and at 1e-7 against exact
    newton MODEL N [GRID]   Newton on the exact problem from the artifact's (ε_f) root, with the
                            exact Jacobian checked against central differences of the residual
    jump   MODEL N EPS,EPS,… [GRID]   up the smoothing homotopy from the artifact to each ε, and
                            from each, Newton at ε = 0 (can the small-ε continuation be skipped?)
    model  FROM TO N STEPS [GRID]   the force-model blend FROM → TO (chain.continue_in_model) at
                            ε = 0: τ in STEPS uniform steps from FROM's artifact, secant predictor,
                            Newton corrector; the end point against TO's artifact
    family MODEL N START TF_FROM TF_TO STEP [GRID]   the fixed-time family on the exact map from a
                            saved solution: m_f and φ = p_t(K_f) against t_f (days)
    walk   MODEL N START H POINTS [GRID]   pseudo-arclength along that family on the exact map, through
                            folds, from a saved solution uphill in m_f: t_f, m_f, φ per point
    rescue MODEL N START [GRID]   Newton at ε = 0 from a failed solve's path checkpoint (.npz) or
                            saved solution (.json)
    -v (anywhere)           prints the corrector's residual by row at every iteration (family, rescue)

The thirtieth session's measurements (docs/perturbed-e6-e7-e8.md, "Thirtieth session") were made
with this spike's own map. The library's version, compiled in one loop per pass, with the τ
column and the event threshold set per arc, is :mod:`spaceopt.indirect.exact_switching`
(thirty-sixth session), and the E8 route on it is ``benchmarks/perturbed.py --exact-route``.
"""
from __future__ import annotations

import dataclasses
import json
import math
import sys
import time
from functools import partial

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import yaml

from spaceopt.indirect import chain, flow, hamiltonians as hm, shooting as S
from spaceopt.studies import perturbed as P

VERBOSE = "-v" in sys.argv        # per-iteration residuals of the corrector (family, rescue)
WALK_TOL = 3e-7           # |F|max of a walk point: the exact map's t(K_f) is noisy at ~1e-7 TU (500 rev)
WALK_LAST = "/tmp/e8_walk_last.npy"   # the walk's last point x = (z, t_f in days), for a look at S there
SEGMENT_STEPS = 512        # steps per diffeqsolve call of pass 1 (its dense output is sized by it)
S_NOISE = 1e-10            # |S| of the integration error at a switch (S itself is of order 1e-2 here)


def problem(model_name: str, n: float):
    """The E8 OT shooting layout and transfer of ``model_name`` at ``n`` revolutions (config)."""
    pc = yaml.safe_load(open("config/studies/perturbed.yaml"))["perturbed"]
    eph = P.ephemeris_path("results", pc["cases"]["e8"]["ephemeris"])
    tr = P.transfer_from_config(pc, "e8", model_name, n_rev=n, ephemeris=eph)
    return chain.shooting_for("ot", "eps", tr), tr


def fixed_time_problem(model_name: str, n: float, grid: float):
    """The exact map of the fixed-time layout (t(K_f) = t_f replaces p_t(K_f) = 0, the end game's
    family, :mod:`spaceopt.indirect.free_time`) and the transfer's units."""
    sh, tr = problem(model_name, n)
    return ExactSwitching(dataclasses.replace(sh, fixed_time=True), tr.params(), grid), tr.units()


def saved_start(path: str):
    """(z, t_f in days) of a saved solution (.json), e.g. the end game's ``free_time_start.json``."""
    data = json.load(open(path))
    return np.asarray(data["z"]), float(data["scalars"]["tof_days"])


def mass_and_phi(ex, yf, units):
    """(m_f in kg, φ = p_t(K_f)) of the trajectory ending in ``yf``."""
    return float(yf[hm.MASS]) * units["mass_kg"], float(yf[ex.n + hm.TIME])


def load(model_name: str, n: float, with_transfer: bool = False):
    art = json.load(open(f"results/perturbed/e8/{model_name}_n{n:g}.json"))
    sh, tr = problem(model_name, n)
    return (art, sh, tr.params(), tr) if with_transfer else (art, sh, tr.params())


class ExactSwitching:
    """Residual and Jacobian of the OT shooting map of ``sh`` (τ = 1) with δ = 1[S > 0]."""

    def __init__(self, sh: S.Shooting, prm: dict, grid: float, tau: float = 1.0):
        self.sh, self.grid, self.n = sh, grid, sh.model.n
        self.prm = {**prm, "eps_final": 0.0}        # smooth_delta(S, 0) = 1[S > 0], dδ/dS = 0
        self.set_tau(tau)                           # of the model blend 'model' (1 otherwise)
        self.rtol, self.atol = sh.rtol, sh.atol
        self.time_unit_s = float(prm["tu"])
        model, n = sh.model, self.n

        def g(K, y, delta, prm):
            out = flow.hamiltonian_field(partial(hm.h_ot, prm=prm, delta=delta), K, y, n)
            if model.perturbed:
                out = out + flow.hamiltonian_field(
                    lambda K_, x_, l_: flow._h_perturbation(model, K_, x_, l_, prm["tau"], prm, 0.0), K, y, n)
            return out

        def switching(K, y, prm):
            return hm.switching_ot(K, y[:n], y[n:], prm)

        def controller():
            return diffrax.PIDController(rtol=self.rtol, atol=self.atol, norm=flow._primal_rms)

        @jax.jit
        def arc(K0, K1, y0, delta, prm):
            def cond(t, y, args, **kw):
                return (2.0 * args[0] - 1.0) * switching(t, y, args[1]) < -S_NOISE
            event = diffrax.Event(cond)
            sol = diffrax.diffeqsolve(
                diffrax.ODETerm(lambda K, y, a: g(K, y, *a)), diffrax.Dopri8(), t0=K0, t1=K1, dt0=None,
                y0=y0, args=(delta, prm), stepsize_controller=controller(),
                saveat=diffrax.SaveAt(t1=True, dense=True), max_steps=SEGMENT_STEPS, throw=False, event=event)
            return sol.ts[-1], sol.ys[-1], sol.stats["num_steps"], sol.event_mask, sol

        @partial(jax.jit, static_argnums=0)
        def sampled(M, sol, Ka, Kb, delta, prm):
            ks = Ka + (Kb - Ka) * jnp.arange(1, M + 1) / M
            return ks, (2.0 * delta - 1.0) * jax.vmap(lambda k: switching(k, sol.evaluate(k), prm))(ks)

        @jax.jit
        def bisect(sol, Ka, Kb, delta, prm):
            def side(k):
                return (2.0 * delta - 1.0) * switching(k, sol.evaluate(k), prm) > 0

            def body(_, ab):
                m = 0.5 * (ab[0] + ab[1])
                return jnp.where(side(m), m, ab[0]), jnp.where(side(m), ab[1], m)
            a, b = jax.lax.fori_loop(0, 60, body, (Ka, Kb))
            k = 0.5 * (a + b)
            return k, sol.evaluate(k)

        @jax.jit
        def restep(sol, Ks, delta, prm):
            """y(K_s) stepped from the last accepted step point before K_s (not the dense output)."""
            ts = sol.interpolation.ts
            tj = ts[jnp.maximum(jnp.searchsorted(ts, Ks, side="right") - 1, 0)]
            out = diffrax.diffeqsolve(
                diffrax.ODETerm(lambda K, y, a: g(K, y, *a)), diffrax.Dopri8(), t0=tj, t1=Ks, dt0=None,
                y0=sol.evaluate(tj), args=(delta, prm), stepsize_controller=controller(),
                saveat=diffrax.SaveAt(t1=True), max_steps=64, throw=False)
            return out.ys[-1]

        @jax.jit
        def arc_with_sensitivities(K0, K1, y0, Phi0, delta, prm):
            def rhs(K, Y, args):
                gy, lin = jax.linearize(lambda yy: g(K, yy, delta, prm), Y[0])
                return gy, jax.vmap(lin, in_axes=1, out_axes=1)(Y[1])
            sol = diffrax.diffeqsolve(diffrax.ODETerm(rhs), diffrax.Dopri8(), t0=K0, t1=K1, dt0=None,
                                      y0=(y0, Phi0), stepsize_controller=controller(),
                                      saveat=diffrax.SaveAt(t1=True), max_steps=sh.max_steps, throw=False)
            return sol.ys[0][-1], sol.ys[1][-1], sol.stats["num_steps"]

        @jax.jit
        def saltation(K, y, Phi, d_old, prm):
            gm, gp = g(K, y, d_old, prm), g(K, y, 1.0 - d_old, prm)
            S_K, S_y = jax.grad(switching, argnums=(0, 1))(K, y, prm)
            return Phi + jnp.outer(gm - gp, -(S_y @ Phi) / (S_K + S_y @ gm))

        self.g, self.switching = jax.jit(g), jax.jit(switching)
        self._arc, self._sampled, self._bisect, self._restep = arc, sampled, bisect, restep
        self._arc_sens, self._saltation = arc_with_sensitivities, saltation

    def set_tau(self, tau: float):
        self.tau = float(tau)
        self.prm = {**self.prm, "tau": jnp.asarray(tau, dtype=float)}

    def set_tf(self, days: float):
        """t_f of a fixed-time layout (``Shooting.fixed_time``), in days."""
        self.prm = {**self.prm, "tf": jnp.asarray(days * 86400 / self.time_unit_s)}

    def switches(self, y0, Kf):
        """Pass 1: (δ at K = 0, switch points K_s, y(K_f), steps, switches found by sampling)."""
        K, y = 0.0, y0
        delta = float(self.switching(0.0, y0, self.prm) > 0)
        d0, Ks, steps, sampled = delta, [], 0, 0
        while True:
            K1, y1, st, hit, sol = self._arc(K, Kf, y, delta, self.prm)
            steps += int(st)
            Kend = float(K1)
            M = max(4, 2 ** math.ceil(math.log2(max((Kend - K) / self.grid, 1.0))))
            ks, s = self._sampled(M, sol, K, Kend, delta, self.prm)
            s = np.asarray(s)
            # the crossing: a sample on the wrong side after one on the right side (just after
            # a switch S is still ≈ 0, and its sign there is noise)
            right = np.nonzero(s > 0)[0]
            below = np.nonzero(s[right[0]:] <= 0)[0] + right[0] if len(right) else []
            if len(below):
                j = int(below[0])
                K1, _ = self._bisect(sol, float(ks[j - 1]), float(ks[j]), delta, self.prm)
                y1 = self._restep(sol, K1, delta, self.prm)
                sampled += int(not bool(hit))
            elif bool(hit):
                raise RuntimeError(f"arc from K = {K}: S never on the throttle's side before the event")
            else:
                if Kend >= Kf:
                    return d0, Ks, y1, steps, sampled
                K, y = Kend, y1                     # SEGMENT_STEPS reached inside the arc
                continue
            K, y = float(K1), y1
            Ks.append(K)
            delta = 1.0 - delta

    def propagate_with_sensitivities(self, y0, Phi0, Kf, d0, Ks):
        """Pass 2: y(K_f), Φ(K_f), δ on the last arc, steps."""
        y, Phi, delta, K, steps = y0, Phi0, d0, 0.0, 0
        for Ks_i in list(Ks) + [Kf]:
            y, Phi, st = self._arc_sens(K, Ks_i, y, Phi, delta, self.prm)
            steps += int(st)
            if Ks_i < Kf:
                Phi = self._saltation(Ks_i, y, Phi, delta, self.prm)
                delta = 1.0 - delta
            K = Ks_i
        return y, Phi, delta, steps

    def residual(self, z):
        sh, prm, kf = self.sh, self.prm, self.sh.kf_index
        y0 = S.initial_state(sh, z, prm)
        _, _, yf, steps, _ = self.switches(y0, float(z[kf]))
        f = jnp.concatenate([jnp.atleast_1d(S.transversality(sh, z, self.tau, prm)),
                             S.terminal_residual(sh, yf, z[kf], prm, self.tau)])
        return f, yf, steps

    def shoot(self, z):
        """f(z), ∂f/∂z, y(K_f), steps of both passes, switches, switches found by sampling."""
        sh, prm, kf = self.sh, self.prm, self.sh.kf_index
        Kf = float(z[kf])
        y0, dy0_dz, _ = S.start_with_sensitivities(sh, z, self.tau, prm)
        d0, Ks, _, steps1, sampled = self.switches(y0, Kf)
        yf, Phif, d_last, steps2 = self.propagate_with_sensitivities(y0, dy0_dz, Kf, d0, Ks)
        r_term, dr_dy, dr_dK, _ = S.terminal_with_derivatives(sh, yf, z[kf], self.tau, prm)
        dyf_dz = jnp.insert(Phif, kf, self.g(z[kf], yf, d_last, prm), axis=1)
        J_term = (dr_dy @ dyf_dz).at[:, kf].add(dr_dK)
        r0, dr0_dz, _ = S.transversality_with_derivatives(sh, z, self.tau, prm)
        f = jnp.concatenate([jnp.atleast_1d(r0), r_term])
        J = jnp.concatenate([dr0_dz[None, :], J_term], axis=0)
        return f, J, yf, (steps1, steps2), len(Ks), sampled


def against(y_ref, yf, units):
    """(Δm_p in kg, Δt in days) of the trajectory ending in ``yf`` against the one ending in ``y_ref``."""
    return ((float(y_ref[hm.MASS]) - float(yf[hm.MASS])) * units["mass_kg"],
            (float(yf[hm.TIME]) - float(y_ref[hm.TIME])) * units["time_s"] / 86400)


def timed(fn, *args):
    t0 = time.perf_counter()
    out = jax.block_until_ready(fn(*args))
    return out, time.perf_counter() - t0


def cost(model_name: str, n: float, grid: float):
    art, sh, prm = load(model_name, n)
    z = jnp.asarray(art["z"])
    Kf = float(z[sh.kf_index])
    y0, dy0_dz, dy0_dtau = S.start_with_sensitivities(sh, z, 1.0, prm)
    Phi0 = jnp.concatenate([dy0_dz, dy0_dtau[:, None]], axis=1)
    smoothed = jax.jit(lambda e: flow.propagate_with_sensitivities(
        sh.model, y0, Phi0, Kf, 1.0, {**prm, "eps_final": e}, sh.rtol, sh.atol, sh.max_steps))
    smoothed_primal = jax.jit(lambda e: flow.propagate(
        sh.model, y0, Kf, 1.0, {**prm, "eps_final": e}, sh.rtol, sh.atol, sh.max_steps))
    eps_f = float(prm["eps_final"])
    ref = {}
    for e in (eps_f, 1e-7):
        smoothed(e), smoothed_primal(e)
        ref[e], t_jac = timed(smoothed, e)
        (_, st_p, _), t_res = timed(smoothed_primal, e)
        print(f"smoothed ε {e:g}: Jacobian propagation {int(ref[e][2])} steps {t_jac:.2f} s; "
              f"residual propagation {int(st_p)} steps {t_res:.2f} s", flush=True)
    ex = ExactSwitching(sh, prm, grid)
    ex.switches(y0, Kf)
    t0 = time.perf_counter()
    d0, Ks, yf1, steps1, sampled = ex.switches(y0, Kf)
    t1 = time.perf_counter() - t0
    ex.propagate_with_sensitivities(y0, dy0_dz, Kf, d0, Ks)
    (yf, Phif, _, steps2), t2 = timed(lambda: ex.propagate_with_sensitivities(y0, dy0_dz, Kf, d0, Ks))
    print(f"exact: pass 1 {steps1} steps, {len(Ks)} switches ({sampled} found by sampling), {t1:.2f} s; "
          f"pass 2 {steps2} steps {t2:.2f} s; Jacobian propagation {t1 + t2:.2f} s", flush=True)
    yr, Pr = ref[1e-7][0], ref[1e-7][1][:, :-1]
    rel = lambda a, b: float(jnp.linalg.norm(a - b) / jnp.linalg.norm(b))
    print(f"max |Δy(K_f)| against ε 1e-7: exact {float(jnp.max(jnp.abs(yf - yr))):.2e} (pass 1 against "
          f"pass 2 {float(jnp.max(jnp.abs(yf - yf1))):.2e}), ε_f {float(jnp.max(jnp.abs(ref[eps_f][0] - yr))):.2e}")
    print(f"‖ΔΦ‖/‖Φ‖ against ε 1e-7: exact {rel(Phif, Pr):.2e}, ε_f {rel(ref[eps_f][1][:, :-1], Pr):.2e}")


def newton(model_name: str, n: float, grid: float, iterations: int = 6):
    art, sh, prm = load(model_name, n)
    ex = ExactSwitching(sh, prm, grid)
    z = jnp.asarray(art["z"])
    f, J, yf, steps, n_sw, sampled = ex.shoot(z)          # compiles
    h = 1e-7
    cols = []
    for j in range(len(z)):
        dz = jnp.zeros_like(z).at[j].set(h * max(1.0, abs(float(z[j]))))
        cols.append((ex.residual(z + dz)[0] - ex.residual(z - dz)[0]) / (2 * dz[j]))
    Jfd = jnp.stack(cols, axis=1)
    print(f"exact Jacobian against central differences (h 1e-7 relative): "
          f"‖ΔJ‖/‖J‖ {float(jnp.linalg.norm(J - Jfd) / jnp.linalg.norm(J)):.2e}; by column "
          + " ".join(f"{float(jnp.linalg.norm(J[:, j] - Jfd[:, j]) / jnp.linalg.norm(J[:, j])):.1e}"
                     for j in range(len(z))), flush=True)
    y_ref, _ = S.final_state(sh, jnp.asarray(art["z"]), 1.0, prm)      # the smoothed trajectory
    m0, t0_ = float(y_ref[hm.MASS]), float(y_ref[hm.TIME])
    print(f"at the ε_f root: |F|max {float(jnp.max(jnp.abs(f))):.2e}, {n_sw} switches", flush=True)
    for it in range(iterations):
        (f, J, yf, steps, n_sw, sampled), t_jac = timed(ex.shoot, z)
        fmax = float(jnp.max(jnp.abs(f)))
        print(f"iteration {it}: |F|max {fmax:.2e}, Jacobian {t_jac:.2f} s (steps {steps[0]} + {steps[1]}), "
              f"{n_sw} switches ({sampled} by sampling), m(K_f) − m_εf {float(yf[hm.MASS]) - m0:+.3e}, "
              f"t(K_f) − t_εf {float(yf[hm.TIME]) - t0_:+.3e}", flush=True)
        if fmax < 1e-10:
            break
        z = z - jnp.linalg.solve(J, f)
    (f, yf, steps), t_res = timed(ex.residual, z)
    print(f"final: |F|max {float(jnp.max(jnp.abs(f))):.2e}, residual {t_res:.2f} s ({steps} steps); "
          f"m_p change {(m0 - float(yf[hm.MASS])):+.3e} (units of m0), Δt change "
          f"{float(yf[hm.TIME]) - t0_:+.3e} TU; z change {np.asarray(z - jnp.asarray(art['z']))}")


def corrector(ex: ExactSwitching, z, tol: float, max_iterations: int = 8, verbose: bool = False):
    """Newton at the exact problem: the last iterate, |F|max there, Jacobians used, wall time."""
    t0 = time.perf_counter()
    for it in range(max_iterations):
        f, J, yf, steps, n_sw, _ = ex.shoot(z)
        fmax = float(jnp.max(jnp.abs(f)))
        if verbose:
            print(f"  iteration {it}: |F|max {fmax:.2e}, {n_sw} switches, |F| by row "
                  + " ".join(f"{abs(float(v)):.1e}" for v in f), flush=True)
        if fmax < tol:
            return z, fmax, it + 1, n_sw, yf, time.perf_counter() - t0
        z = z - jnp.linalg.solve(J, f)
    return z, fmax, max_iterations, n_sw, yf, time.perf_counter() - t0


def model_path(frm: str, to: str, n: float, points: int, grid: float):
    """The force-model blend ``frm`` → ``to`` (chain.continue_in_model) with exact switching:
    τ on a uniform grid of ``points`` steps, secant predictor, Newton corrector."""
    art_from, _, prm_from = load(frm, n)
    art_to, sh_to, prm_to = load(to, n)
    sh = dataclasses.replace(sh_to, model=dataclasses.replace(sh_to.model, homotopy="model"))
    ex = ExactSwitching(sh, {**prm_to, "pert_from": prm_from["pert"]}, grid, tau=0.0)
    start = time.perf_counter()
    z_prev, z, jacobians = None, jnp.asarray(art_from["z"]), 0
    for tau in np.linspace(0.0, 1.0, points + 1):
        ex.set_tau(tau)
        guess = z if z_prev is None else 2 * z - z_prev
        z_new, fmax, its, n_sw, yf, t = corrector(ex, guess, 1e-8 if tau < 1 else 5e-9)
        jacobians += its
        print(f"τ {tau:.3f}: |F|max {fmax:.1e} after {its} Jacobians ({t:.1f} s), {n_sw} switches", flush=True)
        if fmax > 1e-6:
            print("the corrector failed; stop")
            return
        z_prev, z = z, z_new
    total = time.perf_counter() - start
    y_ref, _ = S.final_state(sh_to, jnp.asarray(art_to["z"]), 1.0, prm_to)
    dm, dt = against(y_ref, yf, art_to["units"])
    print(f"{frm} → {to} at {n:g} rev: {jacobians} Jacobians, {total:.0f} s; against the DAG's ε_f artifact: "
          f"m_p {dm:+.2e} kg, Δt {dt:+.2e} d, max |Δz| {float(jnp.max(jnp.abs(z - jnp.asarray(art_to['z'])))):.1e}")


def jump(model_name: str, n: float, eps_list: str, grid: float):
    """From the artifact's ε_f root up the smoothing homotopy to each ε of ``eps_list`` (comma
    separated, increasing; chain.smoothing_to), then Newton at the exact problem from there: can
    the small-ε end of the ε continuation be skipped?"""
    art, sh, prm, tr = load(model_name, n, with_transfer=True)
    ex = ExactSwitching(sh, prm, grid)
    sol = chain.Solution("ot", sh, np.asarray(art["z"]), prm, tr, {})
    y_ref, _ = S.final_state(sh, jnp.asarray(art["z"]), 1.0, prm)
    for eps in (float(e) for e in eps_list.split(",")):
        t0 = time.perf_counter()
        sol = chain.smoothing_to(sol, eps)
        print(f"ε_f → ε {eps:g}: {sol.stats.get('jacobian_evaluations')} Jacobians, {time.perf_counter() - t0:.0f} s",
              flush=True)
        z, fmax, its, n_sw, yf, t = corrector(ex, jnp.asarray(sol.z), 1e-8, max_iterations=10)
        dm, dt = against(y_ref, yf, art["units"])
        print(f"  Newton at ε = 0 from there: |F|max {fmax:.1e} after {its} Jacobians ({t:.0f} s), {n_sw} switches; "
              f"against the ε_f root m_p {dm:+.2e} kg, Δt {dt:+.2e} d", flush=True)


def rescue(model_name: str, n: float, checkpoint: str, grid: float):
    """Newton at ε = 0 from a path checkpoint of a failed E8 solve (.npz: its first single-shooting
    block of z, at τ ≈ 1) or from a saved solution (.json: e.g. the end game's start,
    ``free_time_start.json``): is there an exact-switching root where the ε_f polish stopped?"""
    sh, tr = problem(model_name, n)
    ex = ExactSwitching(sh, tr.params(), grid)
    z0 = jnp.asarray(saved_start(checkpoint)[0] if checkpoint.endswith(".json")
                     else np.load(checkpoint)["z"][:sh.size])
    z, fmax, its, n_sw, yf, t = corrector(ex, z0, 1e-9, max_iterations=6, verbose=VERBOSE)
    u = tr.units()
    print(f"Newton at ε = 0 from {checkpoint}: |F|max {fmax:.1e} after {its} Jacobians ({t:.0f} s), {n_sw} switches; "
          f"m_p {(1.0 - float(yf[hm.MASS])) * u['mass_kg']:.4f} kg, Δt {float(yf[hm.TIME]) * u['time_s'] / 86400:.4f} d; "
          f"max |Δz| from the checkpoint {float(jnp.max(jnp.abs(z - z0))):.1e}", flush=True)


def family(model_name: str, n: float, start: str, tf_from: float, tf_to: float, step: float, grid: float):
    """The fixed-time family (:func:`fixed_time_problem`) on the exact map, t_f from ``tf_from``
    to ``tf_to`` days in ``step``: per point m_f and φ = p_t(K_f) (dm_f/dt_f = −m₀ φ); Newton from
    a secant predictor, starting from the saved solution ``start`` (.json). Stops where Newton
    fails (a fold in t_f)."""
    ex, u = fixed_time_problem(model_name, n, grid)
    z_prev, z = None, jnp.asarray(saved_start(start)[0])
    t0 = time.perf_counter()
    for tf in np.arange(tf_from, tf_to + 0.5 * step, step):
        ex.set_tf(tf)
        guess = z if z_prev is None else 2 * z - z_prev
        z_new, fmax, its, n_sw, yf, t = corrector(ex, guess, 1e-7, max_iterations=6, verbose=VERBOSE)
        if fmax > 1e-6:
            print(f"t_f {tf:.4f} d: Newton failed (|F|max {fmax:.1e} after {its} Jacobians): a fold in t_f, "
                  "or a step too long", flush=True)
            return
        m_f, phi = mass_and_phi(ex, yf, u)
        print(f"t_f {tf:.4f} d: m_f {m_f:.6f} kg, φ {phi:+.3e}, "
              f"{its} Jacobians ({t:.0f} s), {n_sw} switches; {time.perf_counter() - t0:.0f} s in all", flush=True)
        z_prev, z = z, z_new


def walk(model_name: str, n: float, start: str, h: float, points: int, grid: float):
    """Pseudo-arclength along the fixed-time family on the exact map, x = (z, t_f in days), from
    the saved solution ``start`` in the direction of rising m_f, ``points`` points of length ``h``
    (halved on a failed corrector): per point t_f, m_f, φ = p_t(K_f), and where t_f turns (a fold)
    or φ changes sign (a free-time extremal: a local maximum of m_f in t_f where φ goes from − to +
    with t_f rising). Through folds whatever φ is: the end game's ``downhill_folds`` walk, cheaper."""
    ex, u = fixed_time_problem(model_name, n, grid)
    day = 86400 / u["time_s"]
    t_row = ex.sh.size - 1                           # t(K_f) − t_f: ∂/∂t_f[d] = −day

    def evaluate(x):
        ex.set_tf(x[-1])
        f, J, yf, _, n_sw, _ = ex.shoot(jnp.asarray(x[:-1]))
        A = np.zeros((len(f), len(x)))
        A[:, :-1], A[t_row, -1] = np.asarray(J), -day
        return np.asarray(f), A, yf, n_sw

    z0, tf0 = saved_start(start)
    ex.set_tf(tf0)
    z0 = corrector(ex, jnp.asarray(z0), 1e-9, max_iterations=6)[0]     # onto the family at the start's t_f
    x = np.append(np.asarray(z0), tf0)
    f, A, yf, n_sw = evaluate(x)
    m_f, phi_prev = mass_and_phi(ex, yf, u)
    t = np.linalg.svd(A)[2][-1]
    t = t * np.sign(t[-1]) * (1.0 if phi_prev < 0 else -1.0)         # m_f rising
    t0 = time.perf_counter()
    print(f"start t_f {x[-1]:.5f} d: m_f {m_f:.6f} kg, φ {phi_prev:+.3e}, "
          f"|F| {np.max(np.abs(f)):.1e}", flush=True)
    k = 0
    while k < points:
        xp = x + h * t
        xc, ok = xp.copy(), False
        for it in range(6):
            f, A, yf, n_sw = evaluate(xc)
            if np.max(np.abs(f)) < WALK_TOL:
                ok = True
                break
            M = np.vstack([A, t])
            xc = xc - np.linalg.solve(M, np.append(f, t @ (xc - xp)))
        if not ok:
            h *= 0.5
            print(f"  corrector failed (|F| {np.max(np.abs(f)):.1e}); h → {h:.3g}", flush=True)
            if h < 1e-6:
                return
            continue
        t_new = np.linalg.svd(A)[2][-1]
        t_new = t_new * np.sign(t_new @ t)
        fold = np.sign(t_new[-1]) != np.sign(t[-1])
        m_f, phi = mass_and_phi(ex, yf, u)
        k += 1
        print(f"{k:3d} t_f {xc[-1]:.5f} d: m_f {m_f:.6f} kg, φ {phi:+.3e}, "
              f"{it + 1} Jacobians, {n_sw} switches{', FOLD in t_f' if fold else ''}"
              f"{', φ CHANGES SIGN' if np.sign(phi) != np.sign(phi_prev) else ''}; "
              f"{time.perf_counter() - t0:.0f} s", flush=True)
        x, t, phi_prev = xc, t_new, phi
        np.save(WALK_LAST, x)
        if it <= 2:
            h *= 1.5


if __name__ == "__main__":
    sys.argv = [a for a in sys.argv if a != "-v"]
    command = sys.argv[1]
    if command == "jump":
        jump(sys.argv[2], float(sys.argv[3]), sys.argv[4], float(sys.argv[5]) if len(sys.argv) > 5 else 0.02)
    elif command == "rescue":
        rescue(sys.argv[2], float(sys.argv[3]), sys.argv[4], float(sys.argv[5]) if len(sys.argv) > 5 else 0.02)
    elif command == "family":
        family(sys.argv[2], float(sys.argv[3]), sys.argv[4], *map(float, sys.argv[5:8]),
               float(sys.argv[8]) if len(sys.argv) > 8 else 0.02)
    elif command == "walk":
        walk(sys.argv[2], float(sys.argv[3]), sys.argv[4], float(sys.argv[5]), int(sys.argv[6]),
             float(sys.argv[7]) if len(sys.argv) > 7 else 0.02)
    elif command == "model":
        frm, to, n, points = sys.argv[2], sys.argv[3], float(sys.argv[4]), int(sys.argv[5])
        model_path(frm, to, n, points, float(sys.argv[6]) if len(sys.argv) > 6 else 0.02)
    else:
        model_name, n = sys.argv[2], float(sys.argv[3])
        grid = float(sys.argv[4]) if len(sys.argv) > 4 else 0.02
        {"cost": cost, "newton": newton}[command](model_name, n, grid)
