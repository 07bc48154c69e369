"""Continuation in a parameter τ ∈ [τ₀, τ₁]: Davidenko predictor + Newton corrector.

Newton homotopy (3.1.3): f(z(τ), τ) = (1 − τ) b with b = f(z₀, τ₀) (τ₀ = 0), so that any
starting guess lies on the path. Differentiating gives the Davidenko ODE (3.1.4)

    dz/dτ = −[∂f/∂z]⁻¹ (b + ∂f/∂τ),

integrated here by an explicit Euler predictor with adaptive step in τ, followed after every
step by Newton corrections on F(z) = f(z, τ) − (1 − τ) b (spec 01-methods §3.1; the thesis uses
Gragg–Bulirsch–Stoer for the ODE and a few Newton or dogleg corrections — a predictor–corrector
with corrector-driven step control follows the same path and reuses the Jacobian of the last
corrector iteration for the next tangent, so each step costs only the corrector's propagations).

Step control: a step is accepted when the corrector reaches ``tol_step`` within ``max_corrector``
iterations with a contracting Newton sequence (the accepted point gets one more Newton update
with the last Jacobian, at no extra propagation); else it is rejected and shrunk by 0.3. An
accepted step grows by a factor that depends on the iterations used (``step_growth``):
'iterations' — ×2, ×1.5, ×1.2 after 1, 2, 3 corrector evaluations, ×0.8 after more;
'residual' — the same after 2 or more, and after one (the predictor landed within ``tol_step``)
by (½ tol_step / |F_pred|)^{1/4} within [0.8, 2], where |F_pred| is the residual at the predicted
point (a predictor error growing like h⁴: E8 450 rev, 4×4 → + Moon, it went from 2e-5 at h to
3e-4 at 2h, where Newton diverged), and never beyond 0.8 of the last rejected step, a cap that
relaxes by ×1.2 per accepted step. ``max_backtracks`` > 0 damps the corrector: a Newton step
that does not halve |F| is halved along its direction before the step is rejected
(:meth:`Continuation._correct`). ``accepted_update``: the extra Newton update of an accepted
point (τ follower) is not checked; with 'revert', the first step rejected after it is retried from the evaluated point
(whose f and J the predictor uses anyway). On the E8 450-rev lunisolar blend the update threw
the point accepted at τ 0.2915 (|F| 6.7e-5) off the path: every later predictor, down to
h = 7e-4, started from |F| ~ 1e-2. Never updating is no cure: the residual then accumulates
along the path (the test path of tests/test_perturbed_config.py stalls), and 'revert' is no
general gain either (on that path at c = 100 it makes the iteration-count rule underflow, the
accepted point lying at the edge of Newton's basin). At τ₁ a final Newton polish reaches
``tol_final``. ``checkpoint_dir``: both followers save their state after every accepted step
to ``<checkpoint_dir>/<label>.npz`` (atomically) and a later run of the same path (same label,
same starting point and end points) resumes from it with the same steps; the file is removed
once the path is done (and the directory, once empty): E8's lunisolar steps at 450–500
revolutions take hours. ``step_rcond`` > 0: the corrector's (and the accepted update's) Newton
steps are truncated-SVD steps, the directions of the Jacobian with σ < step_rcond σ_max left
out, and the final polish starts with such steps (then Newton's). Measured at E8 450 rev, 4×4 →
4×4 + Moon + Sun (multiple shooting, 10 arcs, at the point accepted at τ 0.9986 with |F| 1e-4):
ten singular values below 3e-6 σ_max (left vectors on the node-time rows), whose residual
components (~1e-7) Newton resolves by a step of 0.025 into the nonlinear region (|F| → 2.9e-3;
any fraction of it ≥ 0.1 fails too); the step truncated at 1e-5 brings |F| to 6e-7, the next
to the flat part alone (docs/perturbed-e6-e7-e8.md, "eighth session"). ``flat_step`` > 0: where
the final polish fails, a root is sought along the flattest direction of J (Lyapunov–Schmidt
reduction, :meth:`Continuation._flat_root`): with v, u the last right and left singular vectors,
the points x with v·(x − z) = s whose residual has no component outside u form a curve (the
valley); on it f reduces to the scalar g(s) = u·f, found by chord steps with J held fixed, and
s is marched in steps of ``flat_step`` until g changes sign (the other way where |g| doubles
first), then refined by regula falsi, from residual evaluations only (``residual``, no
sensitivities). Newton's step has the right length along v but goes straight where the valley
curves, and lands where J is nearly singular.
Measured at E8 450 rev, 4×4 → 4×4 + Moon + Sun at τ = 1 (10 arcs): σ_min 2.0e-5 (σ_max 3.2e3),
g(0) = −4.7e-7, g = −3.4e-7, −5.5e-7, −1.4e-7, +1.9e-7 at s = 0.01, 0.015, 0.02, 0.03 (scaled
unknowns), the root at s = 0.0227, where σ_min is 1.2e-4 and |F| 6e-10 after one Newton step
(docs/perturbed-e6-e7-e8.md, "ninth session"). ``end_overshoot`` (arclength follower): the
end point at τ = 1 is interpolated linearly between the last point before τ = 1 and the
corrected point past it, an error that grows like the step squared. With ``end_overshoot`` > 0
a step whose corrected point lies past τ = 1 by more than that is retaken with h scaled by
(1 − τ)/(τ_c − τ), so that it lands near τ = 1, and a point accepted within ``end_overshoot``
below τ = 1 is carried to τ = 1 along its tangent: the polish starts on the path (E8 500 rev,
4×4 → full: a step of h 0.3 from τ 0.80 crossed to τ = 1.10, "tenth session"). Written by hand
because the corrector-driven step control and the reuse of the propagated Jacobian have no
counterpart in optimistix/diffrax (which integrate or solve, not both).

``corrector`` 'chord' (a chord, or simplified Newton, corrector): the corrector's first
evaluation, at the predicted point, is the full one (f, ∂f/∂z, ∂f/∂τ); its later steps keep that
Jacobian and evaluate f alone (``path_residual``, the path tolerances), so a step costs one
Jacobian however many corrector steps it takes. Where a chord step reduces |F| without halving
it, the Jacobian is evaluated afresh at that point and the chord steps go on from it (instead of
a rejection). The accepted point's Newton update and the next predictor use the held Jacobian,
taken at the predicted point rather than at the accepted one: the tangent is off by the
corrector's distance, which the next corrector absorbs. ``max_chord`` bounds the evaluations of a
step, and the step growth rule counts them from the second (the first costs what a Newton
corrector's first does, the others about an eighth of it). Measured on E8 LP → OT (arclength,
ε₁) at 200 revolutions: a residual costs 0.09 s against 0.77 s for the full evaluation;
Newton's corrector 109 Jacobians, 34 steps, 83 s; the chord corrector 52 Jacobians and 120
residuals, 40 steps, 52 s, the same extremal (m_p to 1e-9; docs/perturbed-e6-e7-e8.md,
"thirty-seventh session"). ``corrector`` 'broyden' (Broyden's corrector, Jacobian reuse across steps):
as the chord corrector, but the Jacobian is carried from step to step and kept current by
Broyden's rank-one update B ← B + (ΔF − B Δu) Δuᵀ/|Δu|² after every evaluation of f alone (the
first from the last accepted point to the predicted one; arclength: B = [∂f/∂z, ∂f/∂τ + b], τ
follower: ∂f/∂z alone, both points at one τ), the predictor's tangent from it; a fresh Jacobian
only where a step reduces |F| without halving it (at its end, as the chord) or not at all (the
step retaken from its start with J there, once). A predicted point whose propagation fails
then costs f alone up to the step cap, not f with its sensitivities. Measured on E8 LP → OT
(arclength, ε₁, path rtol 1e-7, each count one process, Broyden's then the chord): Jacobians 19–25
against 52–81, residuals about twice as many, 1.2–1.6× the steps, the same extremals (m_p to
3e-11 relative); the chord's wall time over Broyden's ≈ 1 (200 rev), 0.89 (250), 1.56, 1.29,
1.17, 2.98 (450) and 2.15 (500). At 450 the chord's second Jacobian alone took 89 s: the first
predicted point's propagation ran to the step cap (450 000 steps) with its sensitivities; a
Jacobian costs 5.6–6.7 residuals at the path's start at 250–500 (docs/perturbed-e6-e7-e8.md,
"fifty-fifth session").
``polish_crossings`` > 0: the final polish of a map with edges,
where f jumps (the exact bang-bang map where a flat arc is born), steps across an edge that many
times and then keeps to the side it reached (:meth:`Continuation._newton_polish`).
"""
from __future__ import annotations

import hashlib
import os
import re
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ConvergenceError


@dataclass
class ContinuationOptions:
    h_init: float = 0.05
    h_min: float = 1e-7
    h_max: float = 0.25
    tol_step: float = 1e-4
    tol_final: float = 1e-10
    max_corrector: int = 4
    max_final: int = 12
    max_steps: int = 2000
    verbose: bool = True
    label: str = ""
    step_growth: str = "iterations"     # or 'residual' (module docstring)
    max_backtracks: int = 0             # damped Newton in the corrector (Continuation._correct)
    accepted_update: str = "always"     # or 'revert' (module docstring)
    checkpoint_dir: str = ""            # resumable paths (module docstring); "" = none
    step_rcond: float = 0.0             # truncated-SVD corrector steps (module docstring); 0 = Newton
    flat_step: float = 0.0              # a failed final polish: the flattest direction's root (module docstring); 0 = none
    flat_max_steps: int = 20            # valley points the march tries at most
    flat_chord: int = 30                # chord steps per valley point; secant steps at most
    flat_restarts: int = 3              # rounds of flat root + Newton in the final polish (_polish)
    end_overshoot: float = 0.0          # arclength: landing on τ = 1 (module docstring); 0 = none
    corrector: str = "newton"           # or 'chord' | 'broyden': corrector steps without a Jacobian (module docstring)
    max_chord: int = 6                  # chord corrector: evaluations per step at most
    polish_crossings: int = 0           # final polish: steps taken across an edge of the map (_newton_polish)


@dataclass
class ContinuationStats:
    steps: int = 0
    rejected: int = 0
    jacobians: int = 0
    residuals: int = 0                  # residual evaluations without Jacobian (_flat_root)
    integration_steps: int = 0
    residual: float = float("nan")
    wall_time_s: float = 0.0
    resumed_wall_time_s: float = 0.0    # of wall_time_s, spent by earlier runs (checkpoint_dir)
    history: list = field(default_factory=list)

    def as_dict(self):
        return {"steps": self.steps, "rejected_steps": self.rejected,
                "jacobian_evaluations": self.jacobians, "residual_evaluations": self.residuals,
                "integration_steps_total": self.integration_steps,
                "final_residual": self.residual, "wall_time_s": self.wall_time_s,
                "resumed_wall_time_s": self.resumed_wall_time_s}


GROWTH = ("iterations", "residual")
CORRECTORS = ("newton", "chord", "broyden")
POLISH_FAILED = "final Newton polish did not converge"     # the diagnosis reason (chain._run_multiple)
ACCEPTED_UPDATES = ("always", "revert")
ITERATION_GROWTH = {1: 2.0, 2: 1.5, 3: 1.2}
SECANT_OVERSHOOT = 1.5      # the flat march's step past the root its secant predicts (_march_valley)


def failure_statistics(diagnosis: dict) -> dict:
    """A failure's diagnosis without its unknowns (``z``, ``z_best``) and step history: the
    statistics of a stage that goes on from it (chain._run_multiple, chain.continue_in_model)."""
    return {k: v for k, v in diagnosis.items() if k not in ("z", "z_best", "history")}


def _fingerprint(z0, tau0, tau1) -> str:
    return hashlib.sha256(np.asarray(z0, float).tobytes() + np.asarray([tau0, tau1], float).tobytes()).hexdigest()


class Checkpoint:
    """The state after the last accepted step of one path (τ or arclength follower),
    ``<directory>/<label>.npz``, tied to the path's start (a file of another start is ignored
    and later overwritten)."""

    COUNTERS = ("steps", "rejected", "jacobians", "integration_steps")

    def __init__(self, directory: str, label: str, z0, tau0, tau1):
        name = re.sub(r"[^A-Za-z0-9._-]+", "_", label).strip("_") or "path"
        self.path = Path(directory) / f"{name}.npz"
        self.key = _fingerprint(z0, tau0, tau1)

    def load(self):
        """The saved state (:meth:`save`), or None."""
        try:
            with np.load(self.path) as d:
                if str(d["key"]) != self.key:
                    return None
                return {k: d[k].copy() for k in d.files if k != "key"}
        except (OSError, KeyError, ValueError):
            return None

    def save(self, stats, **state):
        """``state``: the accepted point z, the evaluated point z_eval whose f and J the next
        predictor uses, τ, the next h and its cap, b, and the last tangent (dz, h) of the
        second-order term: a resumed path takes the same steps as an uninterrupted one."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=self.path.parent, suffix=".npz")
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, key=self.key, **state, wall_time_s=stats.wall_time_s,
                     **{k: getattr(stats, k) for k in self.COUNTERS})
        os.replace(tmp, self.path)

    def remove(self):
        self.path.unlink(missing_ok=True)
        try:
            self.path.parent.rmdir()
        except OSError:
            pass


def resumed_wall_time(record) -> float:
    """The wall time that the paths in ``record`` (solver statistics or a diagnosis: nested
    dicts and lists of :meth:`ContinuationStats.as_dict`) spent in earlier, interrupted runs.
    A record's own ``resumed_wall_time_s`` counts only where nothing nested in it holds one: a
    stage sum (``chain._merge_stats``) is not counted twice."""
    if isinstance(record, dict):
        nested = sum(resumed_wall_time(v) for v in record.values() if isinstance(v, (dict, list, tuple)))
        return nested or float(record.get("resumed_wall_time_s") or 0.0)
    if isinstance(record, (list, tuple)):
        return sum(resumed_wall_time(v) for v in record)
    return 0.0


def _norm(v):
    return float(np.max(np.abs(v)))


def _lstsq(J, r, rcond: float = 0.0):
    """The least-squares solution of J x = r (the arclength follower's solve); ``rcond`` > 0: the
    truncated-SVD solution, the directions of J with σ < rcond σ_max left out
    (``ContinuationOptions.step_rcond``)."""
    return np.linalg.lstsq(J, r, rcond=rcond or None)[0]


def _solve(J, r, rcond: float = 0.0):
    """J⁻¹ r (least squares where J is singular); ``rcond`` > 0: :func:`_lstsq`."""
    if rcond > 0:
        return _lstsq(J, r, rcond)
    try:
        return np.linalg.solve(J, r)
    except np.linalg.LinAlgError:
        return _lstsq(J, r)


class Continuation:
    """Follow f(z(τ), τ) = (1 − τ) b from τ₀ to τ₁ for ``evaluate(z, τ) -> (f, J, f_τ, nsteps, ok)``.

    ``polish`` (same signature, default ``evaluate``) is used for the final Newton iterations at
    τ₁: the path may be followed with looser integration tolerances than the end point needs.
    """

    def __init__(self, evaluate, options: ContinuationOptions | None = None, polish=None, residual=None,
                 path_residual=None):
        self.evaluate = evaluate
        self.polish = polish or evaluate
        self.residual = residual
        self.opt = options or ContinuationOptions()
        if self.opt.step_growth not in GROWTH:
            raise ValueError(f"step_growth {self.opt.step_growth!r}: expected one of {GROWTH}")
        if self.opt.accepted_update not in ACCEPTED_UPDATES:
            raise ValueError(f"accepted_update {self.opt.accepted_update!r}: expected one of {ACCEPTED_UPDATES}")
        if self.opt.corrector not in CORRECTORS:
            raise ValueError(f"corrector {self.opt.corrector!r}: expected one of {CORRECTORS}")
        if self.opt.corrector != "newton" and path_residual is None:
            raise ValueError(f"corrector {self.opt.corrector!r} needs path_residual "
                             "(f at the path tolerances, no derivatives)")
        self.path_residual = path_residual
        self.stats = ContinuationStats()
        self._h_cap = float("inf")      # 0.8 of the last rejected step ('residual' growth)
        self._t_start = time.perf_counter()     # run() restarts it (_elapsed)
        self.last_rejection = ""        # why the corrector gave up last (_correct)
        self.predicted_residual = float("nan")  # |F| where the corrector started last (_correct)

    def _resume(self, z0, tau0, tau1):
        """(checkpoint, saved state or None) of this path (``checkpoint_dir``; (None, None) without
        one); a saved state also restores the counters, the step cap and the wall time spent on
        the path so far (the clock of :meth:`_elapsed` starts that much earlier)."""
        if not self.opt.checkpoint_dir:
            return None, None
        checkpoint = Checkpoint(self.opt.checkpoint_dir, self.opt.label, z0, tau0, tau1)
        saved = checkpoint.load()
        if saved is not None:
            for k in Checkpoint.COUNTERS:
                setattr(self.stats, k, int(saved[k]))
            self._h_cap = float(saved["h_cap"])
            self.stats.resumed_wall_time_s = float(saved.get("wall_time_s", 0.0))
            self._t_start -= self.stats.resumed_wall_time_s
            self._log(f"resumed from {checkpoint.path} at tau={float(saved['tau']):.6f} (h={float(saved['h']):.3g})")
        return checkpoint, saved

    def _eval(self, z, tau, final=False):
        f, J, ftau, nsteps, ok = (self.polish if final else self.evaluate)(z, tau)
        self.stats.jacobians += 1
        self.stats.integration_steps += int(nsteps)
        return np.asarray(f), np.asarray(J), np.asarray(ftau), bool(ok)

    def _residual(self, z, tau):
        """f(z, τ) at the polishing tolerances and its success flag: by ``residual`` where given
        (no derivatives), else by the polishing evaluation."""
        self.stats.residuals += 1
        if self.residual is not None:
            f, ok = self.residual(z, tau)
        else:
            f, _, _, _, ok = self.polish(z, tau)
        return np.asarray(f), bool(ok)

    def _path_f(self, z, tau):
        """f(z, τ) at the path tolerances without derivatives (``path_residual``; chord steps)."""
        self.stats.residuals += 1
        f, ok = self.path_residual(z, tau)
        return np.asarray(f), bool(ok)

    def _elapsed(self):
        """Wall time on this path: since :meth:`run` started, plus that of earlier runs resumed."""
        return time.perf_counter() - self._t_start

    def _save(self, checkpoint, **state):
        """The checkpoint after an accepted step (:meth:`Checkpoint.save`), with the wall time."""
        self.stats.wall_time_s = self._elapsed()
        checkpoint.save(self.stats, **state)

    def _log(self, msg):
        if self.opt.verbose:
            print(f"[{self.opt.label}] {msg}", file=sys.stderr, flush=True)

    def _diagnose(self, reason, z, tau, h, F):
        self.stats.residual = _norm(F) if F is not None else float("nan")
        self.stats.wall_time_s = self._elapsed()
        return ConvergenceError(
            f"{self.opt.label}: continuation failed at tau={tau:.6g} ({reason})",
            {"reason": reason, "tau": tau, "step": h, "z": np.asarray(z).tolist(),
             # the largest τ the path reached: where it turned back (a fold), or stalled
             "tau_max": max([tau, *(e["tau"] for e in self.stats.history if "iters" in e)]),
             "residual": self.stats.residual, **self.stats.as_dict(),
             "history": self.stats.history[-20:]})

    def run(self, z0, tau0=0.0, tau1=1.0, b=None):
        self._t_start = time.perf_counter()
        opt = self.opt
        z = np.asarray(z0, dtype=float).copy()
        span = tau1 - tau0
        tau, h = tau0, opt.h_init * span
        prev_tangent = None
        checkpoint, saved = self._resume(z, tau0, tau1)
        if saved is None:
            f, J, ftau, ok = self._eval(z, tau)
            if not ok:
                raise self._diagnose("integration failed at the starting point", z, tau, 0.0, f)
            b = f.copy() if b is None else np.asarray(b, float)
            F = f - b
        else:       # the state after the last accepted step, its f and J re-evaluated
            tau, h, b = float(saved["tau"]), float(saved["h"]), saved["b"]
            prev_tangent = (saved["tangent"], float(saved["tangent_h"]))
            f, J, ftau, ok = self._eval(saved["z_eval"], tau)
            if not ok:
                raise self._diagnose("integration failed at the checkpoint", saved["z_eval"], tau, h, f)
            z, F = saved["z"], f - (1.0 - (tau - tau0) / span) * b
        checked = None
        while tau1 - tau > 1e-14 * abs(span):
            if self.stats.steps + self.stats.rejected > opt.max_steps:
                raise self._diagnose("too many continuation steps", z, tau, h, F)
            h = min(h, tau1 - tau)
            w = lambda t: 1.0 - (t - tau0) / span        # weight of b: 1 at τ₀, 0 at τ₁
            dz = _solve(J, -(ftau + b / span))           # d/dτ of f − w(τ) b = 0
            zt, tt = z + h * dz, tau + h
            if prev_tangent is not None:                 # second-order term from the last two tangents
                zt = zt + 0.5 * h * h * (dz - prev_tangent[0]) / prev_tangent[1]
            def residual(zz, held=None):
                if held is not None:                     # chord step: f alone, the held J
                    ft, okt = self._path_f(zz, tt)
                    return None if not okt or not np.all(np.isfinite(ft)) else (ft - w(tt) * b, (ft, *held[1:]))
                ft, Jt, fttau, okt = self._eval(zz, tt)
                return None if not okt or not np.all(np.isfinite(ft)) else (ft - w(tt) * b, (ft, Jt, fttau))

            def update(e, dzz, dF):                      # Broyden: J alone (both points at τ = tt)
                return e[0], e[1] + np.outer(dF - e[1] @ dzz, dzz) / np.dot(dzz, dzz), e[2]

            accepted, zt, Ft, ev, nF, iters = self._correct(
                zt, residual, lambda zz, Fz, e: zz + _solve(e[1], -Fz, opt.step_rcond),
                carried=(f, J, ftau), update=update)
            if accepted:
                ft, Jt, fttau = ev
                prev_tangent = (dz, h)
                # one more Newton update with the last Jacobian, without re-evaluating: the
                # residual drops quadratically and the next corrector re-checks it anyway
                # (accepted_update 'revert': the evaluated point is kept for a retry)
                z, tau, f, J, ftau, F = zt + _solve(Jt, -Ft, opt.step_rcond), tt, ft, Jt, fttau, Ft
                checked = zt if opt.accepted_update == "revert" else None
                self.stats.steps += 1
                # |dz/dτ| of the step's predictor grows without bound towards a fold in τ
                self.stats.history.append({"tau": tau, "h": h, "iters": iters, "residual": nF,
                                           "tangent": _norm(dz)})
                self._log(f"tau={tau:.6f} h={h:.3g} corr={iters} |F|={nF:.2e} |dz/dtau|={_norm(dz):.2e} "
                          f"jac={self.stats.jacobians}")
                h = self._grow(h, iters, nF, opt.h_max * abs(span))
                if checkpoint:
                    self._save(checkpoint, z=z, z_eval=zt, tau=tau, h=h, b=b, h_cap=self._h_cap,
                               tangent=prev_tangent[0], tangent_h=prev_tangent[1])
            else:
                self._reject(tau, h)
                h *= 0.3
                if checked is not None:           # retry from the evaluated point (J, f are its)
                    z, checked = checked, None
                    self._log(f"  retry from the accepted point before its Newton update (|F| {_norm(F):.2e})")
                if h < opt.h_min * abs(span):
                    raise self._diagnose("step size underflow", z, tau, h, F)
        # final polish at τ₁ (re-evaluated with the polishing tolerances)
        if self.polish is not self.evaluate:
            f, J, ftau, ok = self._eval(z, tau1, final=True)
            F = f
        out = self._polish(z, J, F, tau1, h, _solve, "done")
        if checkpoint:
            checkpoint.remove()
        return out

    def _grow(self, h, iters, nF, h_max):
        """The step after an accepted step h whose corrector used ``iters`` evaluations and whose
        first evaluation (the predicted point, when iters = 1) had residual ``nF``."""
        if self.opt.corrector != "newton":     # the evaluations after the first cost no Jacobian
            iters = max(1, iters - 1)
        factor = ITERATION_GROWTH.get(iters, 0.8)
        if self.opt.step_growth == "residual":
            if iters == 1:
                factor = min(2.0, max(0.8, (0.5 * self.opt.tol_step / max(nF, 1e-300)) ** 0.25))
            h_next = min(h * factor, self._h_cap)
            self._h_cap *= 1.2
            return min(h_max, h_next)
        return min(h_max, h * factor)

    def _reject(self, tau, h):
        """Count a rejected step from τ with step h; log and record why the corrector gave up."""
        self._h_cap = 0.8 * h
        self.stats.rejected += 1
        self.stats.history.append({"tau": tau, "h": h, "rejected": self.last_rejection})
        self._log(f"  rejected at tau={tau:.6f}, h {h:.3g} -> {0.3 * h:.3g} ({self.last_rejection})")

    def _correct(self, x, residual, newton_step, carried=None, update=None, origin=None):
        """The Newton corrector of both followers: x <- newton_step(x, F, ev) until |F| <= tol_step.

        ``residual(x)`` gives (F, ev), or None when the propagation failed; ``ev`` is the evaluation
        at x that ``newton_step`` and the caller use. A Newton step must at least halve |F|; where
        it does not (or its propagation fails), up to ``max_backtracks`` times the step is halved
        along the same Newton direction, and such a damped point must bring |F| below
        (1 − α/2) of the last (Armijo-like, α the step fraction); then full Newton steps resume.
        Gives up after ``max_corrector`` Newton steps or when no trial contracts. Returns
        (accepted, x, F, ev, |F|, evaluations); on a rejection the reason (the |F| sequence and
        why the corrector gave up) is kept in ``last_rejection`` for the log and the diagnosis.
        With the chord corrector, ``residual(x, held)`` evaluates f alone and
        returns the held evaluation's derivatives (module docstring); ``max_chord`` replaces
        ``max_corrector``. With Broyden's (module docstring) the step starts from the ``carried``
        evaluation (None: a fresh one at x), ``update(ev, Δx, ΔF)`` is its rank-one update after
        each evaluation of f alone, the first from ``origin`` = (x, F) of the last accepted point
        (None: none), and a step that does not reduce |F| at all is retaken from its start with a
        fresh Jacobian there, once.
        """
        opt = self.opt
        chord = opt.corrector != "newton"           # the chord's and Broyden's: steps on a held J
        broyden = opt.corrector == "broyden"
        limit = opt.max_chord if chord else opt.max_corrector
        prev = F = ev = nF = x_prev = d = held = None
        if broyden:
            held, last = carried, origin        # last: (x, F) of the last evaluation, Broyden's secant
        norms, why = [], f"|F| > {opt.tol_step:g} after {limit} iterations"
        evals = newton_steps = backtracks = 0
        alpha = 1.0
        step_exact = False                      # the last step's Jacobian was evaluated at its start
        while True:
            evals += 1
            fresh = held is None                    # the evaluation at x has its own Jacobian
            out = residual(x) if fresh else residual(x, held)
            if out is not None:
                F, ev = out
                if broyden and not fresh and last is not None:
                    ev = update(ev, x - last[0], F - last[1])
                if chord:
                    held = ev
                if broyden:
                    last = (x, F)
                nF = _norm(F)
                if not norms:
                    self.predicted_residual = nF    # |F| at the predictor's point (the log)
                norms.append(nF)
                if nF <= opt.tol_step:
                    return True, x, F, ev, nF, evals
            slow = out is not None and prev is not None and nF > (0.5 if alpha == 1.0 else 1.0 - alpha / 2) * prev
            if slow and not fresh and alpha == 1.0 and nF < prev:
                # a chord step that reduced |F| without halving it: a fresh J at x, the chord on from it
                evals += 1
                out = residual(x)
                if out is not None:
                    F, ev = out
                    held = ev
                    if broyden:
                        last = (x, F)
                    norms.append("(J)")
                    slow = False
            elif broyden and prev is not None and (out is None or slow) and not step_exact and alpha == 1.0:
                # a step by a carried Jacobian that did not reduce |F|: retaken with J at its start
                evals += 1
                out = residual(x_prev)
                if out is not None:
                    F, ev = out
                    held, last, step_exact = ev, (x_prev, F), True
                    norms.append("(J at the step's start)")
                    d = newton_step(x_prev, F, ev) - x_prev
                    x = x_prev + d
                    continue
            if out is None or slow:
                if prev is None or backtracks >= opt.max_backtracks:
                    why = "propagation failed" if out is None else "not contracting"
                    break
                backtracks += 1
                alpha *= 0.5
                norms.append(f"(step x{alpha:g})")
                x = x_prev + alpha * d
                continue
            if newton_steps + 1 >= limit:                   # max_corrector (max_chord) full-step evaluations
                break
            prev, x_prev, alpha = nF, x, 1.0
            step_exact = fresh or norms[-1] == "(J)"
            d = newton_step(x, F, ev) - x
            x = x + d
            newton_steps += 1
        self.last_rejection = f"|F| {' -> '.join(v if isinstance(v, str) else f'{v:.2e}' for v in norms) or '-'}: {why}"
        return False, x, F, ev, nF, evals

    def _polish(self, z, J, F, tau, h, solve, tag):
        """Final Newton iterations at τ (polishing tolerances) while |F| > tol_final and it does not
        double; records the statistics, raises the diagnosis when |F| stays above 1e3 tol_final.
        ``solve(J, r, rcond)``: the step's linear solve. With ``step_rcond``: truncated-SVD steps
        first, while each at least halves |F|, then Newton steps (a truncated step that does not
        reduce |F| is dropped). With ``flat_step``: where that fails, the root along the flattest
        direction (:meth:`_flat_root`), then Newton again; and again from where that stops, with
        the Jacobian there, while each round at least halves |F| (``flat_restarts`` rounds at
        most: the march's chords hold J fixed, and far from where it was taken they stop
        contracting before regula falsi has closed its bracket; E8 450, single shooting:
        docs/perturbed-e6-e7-e8.md, "fifteenth session"). A round whose march found no bracket
        but a valley point with at most half the origin's |g| hands that point, not a root, to
        the next round, without Newton in between. A failed polish's diagnosis has, besides
        where it stopped (``z``), the point of least |F| it evaluated, Newton's iterates and
        the flat march's valley points alike (``z_best``, ``residual_best``): where it stopped
        can be far off (E8 450 rev, single shooting: its start, handed over by the failed
        multiple-shooting polish, has |F| 5e-2, the valley through it 3.5e-7), and a caller
        that can certify an end point another way starts from the best one (the free-time end
        game, :func:`spaceopt.studies.perturbed.end_point_of`)."""
        opt = self.opt
        self._best, self._polish_norms = (np.inf, z), [_norm(F)]
        z, J, F, nF = self._newton_polish(z, J, F, tau, solve, opt.step_rcond)
        for round_ in range(opt.flat_restarts if opt.flat_step > 0 else 0):
            if nF <= opt.tol_final * 1e3:
                break
            found = self._flat_root(z, J, F, tau, later_round=round_ > 0)
            if found is None:
                break
            root, for_newton = found
            f, J_root, _, ok = self._eval(root, tau, final=True)
            self._polish_norms.append(f"(flat root) {_norm(f):.1e}" if ok else "(flat root) failed")
            if not ok or not np.all(np.isfinite(f)):
                break
            if not for_newton:
                # no bracket, but a valley point nearer the root: the next round from there
                z, J, F, nF = root, J_root, f, _norm(f)
                continue
            z_r, J_r, F_r, n_r = self._newton_polish(root, J_root, f, tau, solve, 0.0, at_root=True)
            if n_r >= nF:
                break
            gained = n_r < 0.5 * nF
            z, J, F, nF = z_r, J_r, F_r, n_r
            if not gained:
                break
        self.stats.residual = nF
        self.stats.wall_time_s = self._elapsed()
        if nF > opt.tol_final * 1e3:
            exc = self._diagnose(POLISH_FAILED, z, tau, h, F)
            exc.diagnosis.update({"z_best": np.asarray(self._best[1]).tolist(), "residual_best": self._best[0]})
            raise exc
        self._log(f"{tag}: |F|={nF:.2e} steps={self.stats.steps} rejected={self.stats.rejected} "
                  f"jacobians={self.stats.jacobians} ({self.stats.wall_time_s:.1f} s; polish |F| "
                  f"{' -> '.join(v if isinstance(v, str) else f'{v:.1e}' for v in self._polish_norms)})")
        return z, J

    def _newton_polish(self, z, J, F, tau, solve, rcond, at_root=False):
        """The iterations of :meth:`_polish`: (z, J, F, |F|) where they stop. ``at_root`` (after
        :meth:`_flat_root`): below 1e3 tol_final a step that does not halve |F| ends them, the
        integration noise floor reached (E8 450, 10 arcs: |F|max 6.4e-10, then 7.0e-10; each
        step there costs a Jacobian of ~2 min). ``polish_crossings`` > 0 (a map with edges, where
        f jumps: the exact bang-bang map where an arc is born; module docstring): a step that
        more than doubles |F| is taken anyway that many times, Newton going on from across the
        edge (where the root may lie); after that, a step that raises |F| is shortened (½, ¼, ⅛,
        f alone) to stay on the edge's side it has reached; the best point evaluated is
        returned. E8 200 rev, the jump from ε₁ to the exact map: 1.0e-7 → across → 6.5e-5,
        7.1e-7, a half step 3.5e-7, 1.8e-11."""
        opt = self.opt
        nF = _norm(F)
        self._note_best(z, nF)
        best, crossings = (z, J, F, nF), opt.polish_crossings
        for _ in range(opt.max_final):
            if nF <= opt.tol_final:
                break
            d = solve(J, -F, rcond)
            z_new = z + d
            f_new, J_new, _, ok = self._eval(z_new, tau, final=True)
            n_new = _norm(f_new) if ok and np.all(np.isfinite(f_new)) else np.inf
            self._polish_norms.append(n_new)
            if opt.polish_crossings and n_new > nF and not (crossings and n_new > 2.0 * nF):
                z_new, f_new, J_new, n_new = self._shorter_step(z, d, nF, tau) or (z_new, f_new, J_new, n_new)
            self._note_best(z_new, n_new)
            if n_new < best[3]:
                best = (z_new, J_new, f_new, n_new)
            if rcond > 0 and n_new > 0.5 * nF:
                rcond = 0.0                 # truncated steps no longer gain: Newton from here
                if n_new >= nF:
                    continue
            elif n_new > 2.0 * nF:
                if crossings == 0 or not np.isfinite(n_new):
                    break
                crossings -= 1              # across an edge of the map: Newton goes on from there
            elif at_root and n_new > 0.5 * nF and nF <= opt.tol_final * 1e3:
                if n_new < nF:
                    z, F, J, nF = z_new, f_new, J_new, n_new
                break
            z, F, J, nF = z_new, f_new, J_new, n_new
        if opt.polish_crossings and best[3] < nF:
            z, J, F, nF = best
        return z, J, F, nF

    def _shorter_step(self, z, d, nF, tau):
        """The first of z + d/2, d/4, d/8 whose |f| (f alone) is below ``nF``, evaluated with its
        Jacobian: (z, f, J, |f|); None where none is."""
        for a in (0.5, 0.25, 0.125):
            f, ok = self._residual(z + a * d, tau)
            if ok and np.all(np.isfinite(f)) and _norm(f) < nF:
                f, J, _, ok = self._eval(z + a * d, tau, final=True)
                if ok and np.all(np.isfinite(f)):
                    return z + a * d, f, J, _norm(f)
        return None

    def _note_best(self, z, nF):
        """Keep (|F|, z) as the polish's best point where |F| is the least yet (:meth:`_polish`)."""
        if nF < self._best[0]:
            self._best = (nF, z)

    def _flat_root(self, z, J, F, tau, later_round=False):
        """(x, True): a point for Newton, a root of f(·, τ) along the flattest direction of J
        (Lyapunov–Schmidt; module docstring); (x, False): no root, but a point nearer one, for the
        next round (:meth:`_nearer_root`); or None. With J = U diag(σ) Vᵀ, v and u its last
        singular vectors: on the valley {x : v·(x − z) = s, U_rᵀ f(x) = 0} (U_r: every left vector
        but u) f reduces to the scalar g(s) = u·f. Each valley point by chord steps with J held fixed, x ← x −
        V_r diag(σ_r)⁻¹ U_rᵀ f(x) (they leave s unchanged); s marches from 0 in Newton's
        direction (−sign g(0)), by ``flat_step`` (in a ``later_round`` of :meth:`_polish`, which
        starts near a root, by Newton's distance |g(0)|/σ_min where that is shorter), until g
        changes sign (:meth:`_march_valley`), and with
        the steps left the other way where |g| doubles first; regula falsi on that bracket then
        finds the root (the valley point of least |g|, within 1e-3 |g(0)|).
        A chord point is on the valley where |f_r| < 1e-2 |g(0)| (|g| at s = 0), or where the
        next chord step ‖diag(σ_r)⁻¹ U_rᵀ f‖ is below 1e-3 ``flat_step``: the distance to the
        valley measured in the unknowns, as an affine-covariant Newton method measures
        convergence by its corrections (Deuflhard, Newton Methods for Nonlinear Problems, §2.1),
        for rows whose residual has an integration-noise floor that their large σ turns into a
        negligible step (E8 450, single shooting at τ = 1: |f_r| 1.2e-8 at its floor, mostly on
        the σ_max = 7e4 row of p_t, a step of 3e-13, against 1e-2 |g| = 8.3e-9;
        docs/perturbed-e6-e7-e8.md, "fourteenth session").
        Where the chord through z does not reach the valley, (its best point, True) if it at least
        halved |f|₂, else None. Residual evaluations only (``residual``), no Jacobians."""
        opt = self.opt
        U, S, Vt = np.linalg.svd(J)
        u, v, Ur, Sr, Vr = U[:, -1], Vt[-1], U[:, :-1], S[:-1], Vt[:-1]

        def valley(x, g_ref=None):
            """The chord's best point from x, (x, |f_r|, g, the length of its next chord step),
            and whether it lies on the valley (g_ref: g(0); None: the point's own g)."""
            best, stall = (x, np.inf, np.nan, np.inf), 0
            for _ in range(opt.flat_chord):
                f, ok = self._residual(x, tau)
                if not ok or not np.all(np.isfinite(f)):
                    break
                self._note_best(x, _norm(f))
                c = Ur.T @ f
                reg, step = float(np.linalg.norm(c)), c / Sr
                point = (x, reg, float(u @ f), float(np.linalg.norm(step)))
                best, stall = (point, 0) if reg < best[1] else (best, stall + 1)
                if reg < opt.tol_final or stall >= 4:
                    break
                x = x - Vr.T @ step
            _, reg, g, dist = best
            return best, reg < 1e-2 * abs(g if g_ref is None else g_ref) or dist < 1e-3 * opt.flat_step

        (x, reg, g, dist), on = valley(z)
        if not on:
            # the valley not reached: the chord's point where it at least halved |F|₂ (the polish
            # then decides; E8 500, single shooting: |f_r| 5.6e-9 at its noise floor, g −8.7e-8)
            gain = np.hypot(reg, g) < 0.5 * np.linalg.norm(F)
            self._log(f"  flat direction (sigma {S[-1]:.2e}): the valley through the point not reached "
                      f"(|f_r| {reg:.2e}, chord step {dist:.1e}, g {g:.2e}){'; its chord point kept' if gain else ''}")
            return (x, True) if gain else None
        origin, g0 = (0.0, x, g), g

        def from_origin(x):
            return valley(x, g0)

        newton = -np.sign(g) * (min(opt.flat_step, abs(g) / S[-1]) if later_round else opt.flat_step)
        self._log(f"  flat direction (sigma {S[-1]:.2e} of {S[0]:.2e}): g(0) = {g:+.3e}, marching s by {newton:+.3g}")
        pts, used = self._march_valley(from_origin, v, origin, newton, opt.flat_max_steps)
        marched = pts[1:]
        if np.sign(pts[-1][2]) == np.sign(g) and used < opt.flat_max_steps:
            self._log(f"  no sign change of g that way: marching s by {-newton:+.3g}")
            pts, _ = self._march_valley(from_origin, v, origin, -newton, opt.flat_max_steps - used)
            marched += pts[1:]
        if np.sign(pts[-1][2]) == np.sign(g):
            return self._nearer_root(marched, g0)
        # regula falsi (Illinois) on the bracket: g is not monotone on the scale of a step
        # (E8 500: g = −6.9e-8 at s = −0.025, −1.2e-7 at the plain secant's −0.0230)
        (sa, xa, ga), (sb, xb, gb) = pts[-2], pts[-1]
        tol_g = max(opt.tol_final, 1e-3 * abs(pts[0][2]))
        best = min(pts, key=lambda p: abs(p[2]))
        for _ in range(opt.flat_chord):
            if abs(best[2]) <= tol_g:
                break
            s = sb - gb * (sb - sa) / (gb - ga)
            (x, reg, g, _), on = from_origin(xa + (s - sa) / (sb - sa) * (xb - xa))
            if not on:
                s = 0.5 * (sa + sb)
                (x, reg, g, _), on = from_origin(0.5 * (xa + xb))
                if not on:
                    break
            self._log(f"  regula falsi s = {s:+.6g}: g = {g:+.3e} (|f_r| {reg:.1e})")
            if abs(g) < abs(best[2]):
                best = (s, x, g)
            if np.sign(g) == np.sign(gb):
                sb, xb, gb, ga = s, x, g, 0.5 * ga
            else:
                (sa, xa, ga), (sb, xb, gb) = (sb, xb, gb), (s, x, g)
        return best[1], True

    def _nearer_root(self, marched, g0):
        """Where the march found no sign change: (its valley point of least |g|, False) where
        that |g| is at most half |g(0)|, else None. The chords hold J at the march's origin and
        reach the valley only within a short distance of it where the valley bends; a new round
        from that point, with the Jacobian there, reaches further (E8 500, single shooting, from
        scratch: g(0) −5.3e-7, −5.3e-8 at s = +0.000625, every start beyond it off the valley;
        docs/perturbed-e6-e7-e8.md, "eighteenth session")."""
        nearest = min(marched, key=lambda p: abs(p[2]), default=None)
        if nearest is None or abs(nearest[2]) > 0.5 * abs(g0):
            return None
        s, x, g = nearest
        self._log(f"  no bracket; the next round from s = {s:+.4g} (g = {g:+.3e}), with the Jacobian there")
        return x, False

    def _march_valley(self, valley, v, origin, step, budget):
        """March s along the valley from ``origin`` = (0, x, g(0)) by ``step``, each start
        extrapolated from the last two points (``valley(x)`` → ((x, |f_r|, g, chord step), on the
        valley)): (points, valley points tried, at most ``budget``). Where a start's chords miss
        the valley, the step halves from the last valley point (the extrapolation's error falls
        as the step squared; to step/8, then the march ends). Where the secant through the last
        two valley points puts the root ahead, closer than the step, the step is cut to
        ``SECANT_OVERSHOOT`` times that distance: it then lands just past the root, and its start
        lies near the valley where the valley point is exact (modelled on E8 500, single
        shooting, from scratch: g(0) −5.3e-7, −5.3e-8 at s = +0.000625 after three halvings; that
        point's chords had stalled at |f_r| 3.2e-4, and the cut step missed the valley as the full
        one did: :meth:`_nearer_root` converged that case; docs/perturbed-e6-e7-e8.md,
        "eighteenth session"). It stops at a sign change of g (the
        last two points bracket the root) or where |g| exceeds 2 |g(0)| with g(0)'s sign: the
        valley's curvature outweighs its slope σ_min, and the root lies the other way
        (E8 450, 4×4 → full with h_max 0.1, docs/perturbed-e6-e7-e8.md "twelfth session":
        g(0) +2.4e-7, +6e-7 one step along Newton's direction and growing to +1.8e-6 at
        s = −0.1; against it +2.85e-7, then −1.15e-7 at s = +0.01, the root at +0.0077.
        "Fourteenth session", single shooting: flat_step 0.005 reaches the valley at s = −0.005,
        not at −0.01; flat_step 0.0025 does, and brackets the root in [−0.01, −0.0075])."""
        pts, g0, h = [origin], origin[2], step
        for tried in range(1, budget + 1):
            (s1, x1, g1), prev = pts[-1], pts[-2] if len(pts) > 1 else None
            if prev is not None and g1 != prev[2]:
                ahead = -g1 * (s1 - prev[0]) / (g1 - prev[2])           # the secant's root, from s1
                if ahead * h > 0 and SECANT_OVERSHOOT * abs(ahead) < abs(h):
                    h = SECANT_OVERSHOOT * ahead
            s = s1 + h
            start = x1 + h * (v if prev is None else (x1 - prev[1]) / (s1 - prev[0]))
            (x, reg, g, dist), on = valley(start)
            self._log(f"  s = {s:+.4g}: g = {g:+.3e} (|f_r| {reg:.1e}, chord step {dist:.1e})"
                      f"{'' if on else '; off the valley'}")
            if not on:
                if abs(h) <= abs(step) / 8:
                    return pts, tried
                h *= 0.5
                continue
            pts.append((s, x, g))
            if np.sign(g) != np.sign(g0) or abs(g) > 2.0 * abs(g0):
                return pts, tried
        return pts, budget


STEP_SIZES = ("h_init", "h_min", "h_max", "max_steps")     # the options ArclengthOptions redefines


@dataclass
class ArclengthOptions(ContinuationOptions):
    """Step sizes measured in arclength of u = (z, τ) (``h_min`` absolute, not scaled by the span)."""
    h_init: float = 0.02
    h_min: float = 1e-9
    h_max: float = 0.3
    max_steps: int = 400
    tau_floor: float = -1.0     # the path gave up on τ = 1 once it runs back below this
    runoff_slope: float = 0.0   # > 0: the path given up after runoff_steps accepted steps in a row with |dτ/ds| below this
    runoff_steps: int = 10


class ArclengthContinuation(Continuation):
    """Follow the same Newton homotopy f(z, τ) = (1 − τ) b by pseudo-arclength (passes folds in τ).

    The τ-parametrised corrector of :class:`Continuation` cannot pass a turning point of the
    path (dτ/ds = 0), where it stalls with a vanishing step. Here u = (z, τ) is continued in
    arclength s (Keller): the tangent t spans the null space of [∂f/∂z, ∂f/∂τ + b] (oriented
    along the previous tangent, initially towards increasing τ), the predictor is u + h t and the
    Newton corrector solves (f − (1 − τ) b, t·(u − u_pred)) = 0. Step control as in
    :class:`Continuation`. When a step crosses τ = 1 the end point is interpolated linearly and
    polished at τ = 1 (``polish``). A path that turns back and runs below ``tau_floor`` is given
    up with a diagnosis (E6, 28 May: after a fold at τ 0.78 it ran on to τ = −6). So is, with
    ``runoff_slope`` > 0, a path that runs off in z at a τ short of 1: ``runoff_steps`` accepted
    steps in a row whose tangent has |dτ/ds| < ``runoff_slope`` (a fold passes dτ/ds = 0 in a
    step or two). Measured on E7's full-model hops (seventy-third and seventy-fourth sessions,
    t = (z, τ) with z the scaled unknowns): fixed-time paths with a t_f shorter than the least
    time at the thrust took 24–40 steps in a row below 0.01 (and ran on to the step cap, 400
    steps and 30 min where no lower one was set), while the nine that arrived (5–260 steps) had
    at most one such step (a turn at 0.003; the slowest, 36 steps in a row below 0.03). Same
    ``evaluate`` signature as :class:`Continuation`; here τ₀ = 0, τ₁ = 1.
    """

    def __init__(self, evaluate, options: ContinuationOptions | None = None, polish=None, residual=None,
                 path_residual=None):
        super().__init__(evaluate, options or ArclengthOptions(), polish, residual, path_residual)

    def run(self, z0, tau0=0.0, tau1=1.0, b=None):
        if (tau0, tau1) != (0.0, 1.0):
            raise ValueError("arclength continuation runs from tau = 0 to 1")
        self._t_start = time.perf_counter()
        opt = self.opt
        z = np.asarray(z0, dtype=float).copy()
        tau = 0.0
        checkpoint, saved = self._resume(z, 0.0, 1.0)
        if saved is None:
            f, J, ftau, ok = self._eval(z, tau)
            if not ok:
                raise self._diagnose("integration failed at the starting point", z, tau, 0.0, f)
            b = f.copy() if b is None else np.asarray(b, float)
        else:       # the point, tangent and step after the last accepted step (no re-evaluation)
            b = saved["b"]
        n = z.size

        def tangent(J, ftau, prev=None):
            _, _, vt = np.linalg.svd(np.hstack([J, (ftau + b)[:, None]]))
            t = vt[-1]
            if (prev is not None and np.dot(t, prev) < 0) or (prev is None and t[-1] < 0):
                t = -t
            return t

        if saved is None:
            t = tangent(J, ftau)
            h, F, carried = opt.h_init, f - b, (J, ftau)
        else:       # Broyden's corrector starts with a fresh Jacobian
            z, tau, t, h, F = saved["z"], float(saved["tau"]), saved["tangent"], float(saved["h"]), saved["F"]
            carried = None
        landings = 0
        slow = 0 if saved is None else int(saved.get("slow", 0))    # accepted steps in a row below runoff_slope
        while True:
            if 0 < opt.end_overshoot and 0.0 <= 1.0 - tau <= opt.end_overshoot and t[-1] > 0:
                ds = (1.0 - tau) / t[-1]                    # next to τ = 1: along the tangent
                z, tau = z + ds * t[:n], 1.0
                self.stats.history.append({"tau": 1.0, "h": ds, "iters": 0, "residual": _norm(F)})
                break
            if self.stats.steps + self.stats.rejected > opt.max_steps:
                raise self._diagnose("too many continuation steps", z, tau, h, F)
            u = np.concatenate([z, [tau]])
            up = u + h * t
            def residual(u, held=None):
                if held is not None:                     # chord step: f alone, the held J
                    fc, okc = self._path_f(u[:n], u[n])
                    return None if not okc or not np.all(np.isfinite(fc)) else (fc - (1.0 - u[n]) * b, held)
                fc, Jc, ftc, okc = self._eval(u[:n], u[n])
                return None if not okc or not np.all(np.isfinite(fc)) else (fc - (1.0 - u[n]) * b, (Jc, ftc))

            def newton_step(u, Fc, ev):
                M = np.vstack([np.hstack([ev[0], (ev[1] + b)[:, None]]), t[None, :]])
                return u + _lstsq(M, -np.concatenate([Fc, [np.dot(t, u - up)]]), opt.step_rcond)

            def update(e, du, dF):                       # Broyden on A = [J, f_τ + b]
                A = np.hstack([e[0], (e[1] + b)[:, None]])
                A = A + np.outer(dF - A @ du, du) / np.dot(du, du)
                return A[:, :n], A[:, n] - b

            accepted, uc, Fc, ev, nF, iters = self._correct(up.copy(), residual, newton_step, carried, update,
                                                            (u, F))
            if not accepted:
                self._reject(tau, h)
                h *= 0.3
                if h < opt.h_min:
                    raise self._diagnose("step size underflow", z, tau, h, F)
                continue
            if 0 < opt.end_overshoot < uc[n] - 1.0 and landings < 5:
                landings += 1                       # far past τ = 1: retake the step to land near it
                h *= (1.0 - tau) / (uc[n] - tau)
                self._log(f"past tau = 1 at {uc[n]:.4f}: step retaken with h={h:.3g}")
                continue
            self.stats.steps += 1
            if uc[n] >= 1.0:                        # crossed τ = 1: interpolate, then polish
                lam = (1.0 - tau) / (uc[n] - tau)
                z, tau = z + lam * (uc[:n] - z), 1.0
                self.stats.history.append({"tau": 1.0, "h": h, "iters": iters, "residual": nF})
                break
            if uc[n] < opt.tau_floor:
                raise self._diagnose(f"the path turned back and ran below tau = {opt.tau_floor:g}",
                                     uc[:n], uc[n], h, Fc)
            t = tangent(*ev, t)
            z, tau, F, carried = uc[:n], uc[n], Fc, ev
            self.stats.history.append({"tau": tau, "h": h, "iters": iters, "residual": nF})
            self._log(f"s-step {self.stats.steps}: tau={tau:.6f} h={h:.3g} corr={iters} "
                      f"|F_pred|={self.predicted_residual:.1e} |F|={nF:.2e} "
                      f"dtau/ds={t[-1]:+.3f} jac={self.stats.jacobians}")
            slow = slow + 1 if abs(t[-1]) < opt.runoff_slope else 0
            if slow >= opt.runoff_steps > 0:
                raise self._diagnose(f"the path runs off: {slow} steps in a row with |dtau/ds| < {opt.runoff_slope:g}",
                                     z, tau, h, F)
            h = self._grow(h, iters, nF, opt.h_max)
            if checkpoint:
                self._save(checkpoint, z=z, tau=tau, tangent=t, h=h, b=b, F=F, h_cap=self._h_cap, slow=slow)
        # polish at τ = 1
        f, J, ftau, ok = self._eval(z, 1.0, final=True)
        out = self._polish(z, J, f, 1.0, h, _lstsq, "done (arclength)")
        if checkpoint:
            checkpoint.remove()
        return out
