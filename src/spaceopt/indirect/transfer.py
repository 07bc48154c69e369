"""A physical transfer (SI, degrees) and its nondimensional form for the solvers.

Units (spec 02-multirev §1, verified in §10 for §4.1): length unit DU = semi-major axis of the
final orbit (the final-orbit radius for the circular targets of §4.1), μ = 1, time unit
TU = √(DU³/μ), velocity unit DU/TU, mass unit m₀, force unit m₀·DU/TU². The printed §4.1
costates are in these units.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import jax.numpy as jnp
import numpy as np

from .. import constants
from ..elements import kepler_to_mee
from ..errors import ConfigError


MAX_STEPS = 400_000     # integration steps per propagation unless a study caps them lower
STEP_BOUND = 1 << 20    # the highest cap: diffrax's static loop bound (.flow.StepCap takes the cap traced)
PATH_RTOL = 1e-9        # integration rtol while a homotopy path is followed (end points: Shooting.rtol)
SWITCHINGS = ("smoothed", "exact")     # the throttle δ(S, ε) (3.3.2), or 1[S > 0] (.exact_switching)


def step_cap(n_rev: float, per_rev: float, minimum: int) -> int:
    """An integration-step cap that grows with the revolutions, rounded up to a multiple of
    10 000. A propagation that reaches it fails, so a degenerate trajectory in a continuation
    step is rejected after this many steps rather than MAX_STEPS. The cap is a traced value of
    the compiled programs (.flow.StepCap): every cap shares them."""
    raw = max(int(minimum), int(per_rev * n_rev))
    return int(math.ceil(raw / 10_000) * 10_000)


def datum(value):
    """A problem datum as the shooting maps take it: a float64 array, strongly typed.

    ``jnp.asarray(0.5)`` is weakly typed, and a weakly and a strongly typed scalar are two input
    types to ``jax.jit``: each program a weak datum reaches is traced and compiled once more than
    its strong twin (measured: chain.to_exact's ε_f = 0 compiled the exact map's pass 1 a second
    time, 10 s on E1 J2). Every datum put in a problem's ``prm`` goes through here."""
    return jnp.asarray(value, dtype=jnp.float64)


@dataclass(frozen=True)
class Orbit:
    """Keplerian orbit: a [m], e, i, Ω (raan), ω (argp) [deg]."""
    a: float
    e: float
    i: float
    raan: float = 0.0
    argp: float = 0.0

    def check(self, key):
        if not (math.isfinite(self.a) and self.a > 0):
            raise ConfigError(f"{key}.a", self.a, "semi-major axis must be a positive length in metres")
        if not (0.0 <= self.e < 1.0):
            raise ConfigError(f"{key}.e", self.e, "eccentricity must be in [0, 1) (closed orbit)")
        if not (0.0 <= self.i < 180.0):
            raise ConfigError(f"{key}.i", self.i, "inclination must be in [0, 180) deg")

    def mee5(self, du):
        m = kepler_to_mee(self.a / du, self.e, math.radians(self.i), math.radians(self.raan),
                          math.radians(self.argp), 0.0)
        return np.asarray(m[:5])


@dataclass(frozen=True)
class Transfer:
    initial: Orbit
    final: Orbit
    L0_deg: float
    n_rev: float
    m0: float
    isp: float
    thrust: float = float("nan")
    mu: float = constants.MU_EARTH_THESIS
    eps_final: float = 1e-5
    eps_blend: float = 1e-2
    perturbations: dict | None = None      # forces.build_model config; None = unperturbed
    epoch_utc: str | None = None           # departure epoch (UTC), needed when perturbed
    ephemeris: str | None = None           # ephemeris window artifact (JSON) for third bodies
    tof_s: float | None = None             # fixed time of flight (1.1.11); None = free (optimal) time
    max_steps: int = MAX_STEPS             # integration-step cap of every propagation (step_cap)
    path_rtol: float = PATH_RTOL           # integration rtol along homotopy paths (Shooting.path_rtol)
    path_arcs: int = 1                     # shooting arcs along homotopy paths (Shooting.path_arcs)
    sensitivity_rtol: float | None = None  # the exact map's Jacobian rtol (Shooting.sensitivity_rtol)
    path_step_budget: float | None = None  # a path's step cap relative to its last success (Shooting)

    def integration(self) -> dict:
        """The integration settings every Shooting of this transfer takes (step cap, path rtol,
        path arcs, sensitivity rtol, path step budget)."""
        return {"max_steps": self.max_steps, "path_rtol": self.path_rtol, "path_arcs": self.path_arcs,
                "sensitivity_rtol": self.sensitivity_rtol, "path_step_budget": self.path_step_budget}

    def __post_init__(self):
        self.initial.check("initial")
        self.final.check("final")
        for key, val in (("m0", self.m0), ("isp", self.isp), ("n_rev", self.n_rev), ("mu", self.mu)):
            if not (isinstance(val, (int, float)) and math.isfinite(val) and val > 0):
                raise ConfigError(key, val, "must be a positive number")
        if not (isinstance(self.path_rtol, (int, float)) and 0 < self.path_rtol < 1e-3):
            raise ConfigError("path_rtol", self.path_rtol, "must be a relative tolerance in (0, 1e-3)")
        if self.sensitivity_rtol is not None and not (
                isinstance(self.sensitivity_rtol, (int, float)) and 0 < self.sensitivity_rtol < 1e-3):
            raise ConfigError("sensitivity_rtol", self.sensitivity_rtol, "must be a relative tolerance in (0, 1e-3)")
        if not (isinstance(self.max_steps, int) and not isinstance(self.max_steps, bool)
                and 1 <= self.max_steps <= STEP_BOUND):
            raise ConfigError("max_steps", self.max_steps, f"must be a whole number of steps in [1, {STEP_BOUND}]")
        if self.path_step_budget is not None and not (
                isinstance(self.path_step_budget, (int, float)) and not isinstance(self.path_step_budget, bool)
                and 1 <= self.path_step_budget < math.inf):
            raise ConfigError("path_step_budget", self.path_step_budget,
                              "must be a factor >= 1 on the steps of the path's last successful evaluation")
        if not (isinstance(self.path_arcs, int) and not isinstance(self.path_arcs, bool) and self.path_arcs >= 1):
            raise ConfigError("path_arcs", self.path_arcs, "must be a whole number of shooting arcs >= 1")
        if not math.isnan(self.thrust) and not (math.isfinite(self.thrust) and self.thrust > 0):
            raise ConfigError("thrust", self.thrust, "must be a positive force in newtons")
        if not (0 < self.eps_final < 1):
            raise ConfigError("eps_final", self.eps_final, "smoothing end value must be in (0, 1)")
        if self.tof_s is not None and not (math.isfinite(self.tof_s) and self.tof_s > 0):
            raise ConfigError("tof_s", self.tof_s, "a fixed time of flight must be a positive number of seconds")
        if not (self.eps_final <= self.eps_blend <= 1):
            raise ConfigError("eps_blend", self.eps_blend, "must lie in [eps_final, 1]")

    # units
    @property
    def du(self):
        return self.final.a

    @property
    def tu(self):
        return math.sqrt(self.du**3 / self.mu)

    @property
    def vu(self):
        return self.du / self.tu

    @property
    def force_unit(self):
        return self.m0 * self.du / self.tu**2

    @property
    def c(self):
        """Exhaust velocity c = Isp g0 [m/s]."""
        return self.isp * constants.G0

    @property
    def delta_L(self):
        return 2.0 * math.pi * self.n_rev

    @property
    def perturbed(self) -> bool:
        return bool(self.perturbations)

    def perturbation_model(self):
        from ..forces import build_model
        if self.epoch_utc is None:
            raise ConfigError("epoch_utc", None, "a perturbed transfer needs a departure epoch")
        return build_model(self.perturbations, self.epoch_utc, self.ephemeris)

    def units(self):
        return {"length_m": self.du, "time_s": self.tu, "velocity_m_s": self.vu,
                "mass_kg": self.m0, "force_N": self.force_unit, "mu_m3_s2": self.mu}

    def params(self, thrust=None):
        """Nondimensional problem data for the shooting maps (a pytree of float64 arrays)."""
        L0 = math.radians(self.L0_deg)
        T = self.thrust if thrust is None else thrust
        prm = {k: datum(v) for k, v in {
            "x0": self.initial.mee5(self.du), "xf": self.final.mee5(self.du),
            "L0": L0, "Lf": L0 + self.delta_L, "c": self.c / self.vu,
            "thrust": (0.0 if T is None or math.isnan(T) else T) / self.force_unit,
            "eps_final": self.eps_final, "eps_blend": self.eps_blend, "blend_ref": 1.0,
            "du": self.du, "tu": self.tu,
            "tf": (self.tof_s or 0.0) / self.tu}.items()}
        if self.perturbed:
            prm["pert"] = self.perturbation_model()
        return prm

    def as_dict(self):
        return asdict(self)
