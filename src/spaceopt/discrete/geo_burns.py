"""D1: LEO -> GEO insertion with engine-start penalties (spec 05-discrete.md, section D1).

Model (planar, polar coordinates, thrust along the velocity; state x = (rho, phi, v, omega, m))::

    rho'   = v
    phi'   = omega
    v'     = rho*omega^2 - gM/rho^2 + u*v     / (m*s),      s = sqrt(v^2 + rho^2*omega^2)
    omega' = -2*v*omega/rho        + u*omega / (m*s)
    m'     = -mu*u,                0 <= u <= U_max,  mu*U_max = mass flow at full thrust

Approximate method of the paper (spec D1, "Approximate solution method"): coast arcs are Kepler
arcs (closed form, Kepler's equation solved with scipy's Newton); only the burns are integrated,
with scipy's Dormand-Prince 5(4) (``solve_ivp(method="RK45")``). Every burn of duration dt is
centred on an apsis: coast back dt/2 from the apsis, burn with u = U_max for dt, take the
osculating ellipse after the burn,

    tan(phi - psi) = rho^2 v omega / (rho^3 omega^2 - gM)        (apse-line angle psi)
    e cos(phi - psi) = (rho^3 omega^2 - gM)/gM,  e sin(phi - psi) = rho^2 v omega / gM,
    p = rho^4 omega^2 / gM,

and jump to its next apsis. (The printed formulas e = v/(rho*omega*sin(phi-psi) - v*cos(phi-psi))
and p = rho^2*omega*sin(...)/(...) are the same ellipse, but 0/0 at the apsides where the burns sit;
the two-component form above is used because it is regular there.)

A scheme is (n_p perigee burns of dt_p, the last trimmed, then n_a apogee burns of dt_a, the last
trimmed). For given n_p the duration is the smallest multiple of ``duration_step_s`` with which n_p
burns raise the apogee to the GEO radius; the last burn is trimmed (scipy ``brentq``) so that
r_apogee = R_GEO. The apogee series works the same way with the circularisation condition
(eccentricity vector along the burn apsis = 0). The schemes are then ranked by

    I_lambda = fuel + lambda1*e(t1) + lambda2*(rho(t1) - R_GEO)^2 + lambda3 * (number of starts)

subject to transfer time <= t1 (the vehicle coasts on GEO until t1). lambda3 = 0 gives the
classical scheme, lambda3 > 0 the start-penalised one. The flown scheme is simulated with its given
burn durations.

Readings of the source (``hypothesis_table``): the published classical scheme (7 + 11 burns,
725 033 s) is tested against alternative readings -- time bookkeepings (``TIME_BOOKKEEPINGS``),
count-selection rules, mass flows, apse-rotation definitions (``APSE_ROTATION_REFERENCES``). The
spec's own reading (``apsis_arcs``) reproduces the published durations and fuel but not the time
or the count; docs/d1-geo-burns.md records what every reading gives.

Switching-function check (spec D1, Problem 1): along a simulated schedule the costates obey the
linear adjoint equations psi' = -(df/dx)^T psi (derived with ``jax.jacfwd``, never by hand) and

    k = (v*psi3 + omega*psi4) / (mu*m*s) - psi5,     thrust on where k >= 1.

At t1 the transversality conditions of the penalised cost give psi(t1) = -d/dx[lambda1 e +
lambda2 (rho - R)^2], psi5(t1) = 0. At e = 0 the gradient of e is a subgradient: lambda1 * J^T xi
with J = d(e_x, e_y)/dx and |xi| <= 1, and the rho term is a free multiplier nu. The three numbers
(nu, xi) are fitted by linear least squares to k = 1 at every switching time; the check is that
|xi| <= 1 and that k >= 1 on the burns and k < 1 on the coasts.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, newton

from ..errors import ConfigError

TWO_PI = 2.0 * math.pi
APSE_ROTATION_REFERENCES = ("burn_mid_time", "burn_mid_angle", "apsis")


# --------------------------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class GeoParams:
    gm: float                 # m^3/s^2 (gamma*M)
    thrust_n: float           # U_max
    mass_flow_kg_s: float     # mu*U_max
    m0: float
    r0: float
    r_target: float
    t1: float
    lambda1: float
    lambda2: float
    lambda3: float
    duration_step_s: float
    rtol: float
    atol_scale: float
    apse_rotation_min_ecc: float
    apse_rotation_reference: str = "burn_mid_time"

    @property
    def mu(self) -> float:
        """mu of the model (s/m): m' = -mu*u."""
        return self.mass_flow_kg_s / self.thrust_n


def _positive(cfg, key, prefix):
    try:
        val = float(cfg[key])
    except KeyError:
        raise ConfigError(f"{prefix}.{key}", None, "missing") from None
    except (TypeError, ValueError):
        raise ConfigError(f"{prefix}.{key}", cfg[key], "not a number") from None
    if not math.isfinite(val) or val <= 0.0:
        raise ConfigError(f"{prefix}.{key}", cfg[key], "must be a finite number > 0")
    return val


def _nonneg(cfg, key, prefix):
    val = cfg.get(key)
    try:
        val = float(val)
    except (TypeError, ValueError):
        raise ConfigError(f"{prefix}.{key}", cfg.get(key), "not a number") from None
    if not math.isfinite(val) or val < 0.0:
        raise ConfigError(f"{prefix}.{key}", cfg.get(key), "must be a finite number >= 0")
    return val


def params_from_config(cfg: dict, lambda3: float | None = None,
                       mass_flow_kg_s: float | None = None, prefix: str = "geo_burns") -> GeoParams:
    """Build :class:`GeoParams` from the ``geo_burns`` config section (SI units)."""
    m = cfg.get("model", {})
    c = cfg.get("cost", {})
    n = cfg.get("numerics", {})
    gm = _positive(m, "gamma", f"{prefix}.model") * _positive(m, "earth_mass_kg", f"{prefix}.model")
    r0 = _positive(m, "r0_m", f"{prefix}.model")
    rt = _positive(m, "r_target_m", f"{prefix}.model")
    if rt <= r0:
        raise ConfigError(f"{prefix}.model.r_target_m", m["r_target_m"], "must exceed r0_m")
    flow = mass_flow_kg_s if mass_flow_kg_s is not None else _positive(m, "mass_flow_kg_s", f"{prefix}.model")
    if not (math.isfinite(flow) and flow > 0):
        raise ConfigError(f"{prefix}.model.mass_flow_kg_s", flow, "must be a finite number > 0")
    ref = n.get("apse_rotation_reference", "burn_mid_time")
    if ref not in APSE_ROTATION_REFERENCES:
        raise ConfigError(f"{prefix}.numerics.apse_rotation_reference", ref,
                          "must be one of " + ", ".join(APSE_ROTATION_REFERENCES))
    rtol = _positive(n, "rtol", f"{prefix}.numerics")
    if rtol >= 1e-3:
        raise ConfigError(f"{prefix}.numerics.rtol", n["rtol"], "must be < 1e-3")
    return GeoParams(
        gm=gm, thrust_n=_positive(m, "thrust_max_n", f"{prefix}.model"), mass_flow_kg_s=flow,
        m0=_positive(m, "m0_kg", f"{prefix}.model"), r0=r0, r_target=rt,
        t1=_positive(m, "t1_s", f"{prefix}.model"),
        lambda1=_nonneg(c, "lambda1", f"{prefix}.cost"), lambda2=_nonneg(c, "lambda2", f"{prefix}.cost"),
        lambda3=(_nonneg(c, "lambda3_kg", f"{prefix}.cost") if lambda3 is None else float(lambda3)),
        duration_step_s=_positive(n, "duration_step_s", f"{prefix}.numerics"), rtol=rtol,
        atol_scale=_positive(n, "atol_scale", f"{prefix}.numerics"),
        apse_rotation_min_ecc=_positive(n, "apse_rotation_min_ecc", f"{prefix}.numerics"),
        apse_rotation_reference=ref)


# --------------------------------------------------------------------------------------------
# Dynamics and Kepler geometry
# --------------------------------------------------------------------------------------------
def rhs(t, x, p: GeoParams, u: float):
    rho, _phi, v, om, m = x
    s = math.sqrt(v * v + rho * rho * om * om)
    a = u / (m * s) if u else 0.0
    return [v, om, rho * om * om - p.gm / (rho * rho) + a * v, -2.0 * v * om / rho + a * om,
            -p.mu * u]


@dataclass(frozen=True)
class Orbit:
    """Osculating ellipse of a planar state: semi-latus rectum p, eccentricity e, apse angle psi
    (polar angle of the perigee), and the state's unwrapped true anomaly theta = phi - psi."""
    p: float
    e: float
    psi: float
    theta: float
    mass: float
    t: float

    @property
    def a(self) -> float:
        return self.p / (1.0 - self.e * self.e)

    @property
    def r_apogee(self) -> float:
        return self.p / (1.0 - self.e)

    @property
    def r_perigee(self) -> float:
        return self.p / (1.0 + self.e)


def osculating(x, t: float, gm: float) -> Orbit:
    """Osculating ellipse of x = (rho, phi, v, omega, m) (spec D1 formulas, regular form)."""
    rho, phi, v, om, m = x
    ec = (rho ** 3 * om * om - gm) / gm
    es = rho * rho * v * om / gm
    e = math.hypot(ec, es)
    theta = math.atan2(es, ec) if e > 0 else 0.0
    return Orbit(p=rho ** 4 * om * om / gm, e=e, psi=phi - theta, theta=theta, mass=m, t=t)


def ecc_vector(x, gm, xp=np):
    """Inertial eccentricity vector (points to the perigee) of a polar state; ``xp`` = np or jnp."""
    rho, phi, v, om = x[0], x[1], x[2], x[3]
    ec = (rho ** 3 * om * om - gm) / gm
    es = rho * rho * v * om / gm
    c, s = xp.cos(phi), xp.sin(phi)
    return xp.stack([c * ec + s * es, s * ec - c * es]) if xp is not np else np.array(
        [c * ec + s * es, s * ec - c * es])


def _beta(e):
    return e / (1.0 + math.sqrt(1.0 - e * e))


def _ecc_anomaly(theta, e):
    """Unwrapped eccentric anomaly of an unwrapped true anomaly (continuous branch)."""
    b = _beta(e)
    return theta - 2.0 * math.atan2(b * math.sin(theta), 1.0 + b * math.cos(theta))


def _true_anomaly(E, e):
    b = _beta(e)
    return E + 2.0 * math.atan2(b * math.sin(E), 1.0 - b * math.cos(E))


def mean_motion(orb: Orbit, gm: float) -> float:
    return math.sqrt(gm / orb.a ** 3)


def state_at_time(orb: Orbit, t: float, gm: float) -> np.ndarray:
    """Kepler propagation of the osculating ellipse to time t (closed form + Kepler's equation)."""
    e = orb.e
    E0 = _ecc_anomaly(orb.theta, e)
    M = E0 - e * math.sin(E0) + mean_motion(orb, gm) * (t - orb.t)
    E = newton(lambda E: E - e * math.sin(E) - M, M + e * math.sin(M),
               fprime=lambda E: 1.0 - e * math.cos(E), tol=1e-14, maxiter=50)
    theta = _true_anomaly(E, e)
    r = orb.p / (1.0 + e * math.cos(theta))
    h = math.sqrt(gm * orb.p)
    return np.array([r, orb.psi + theta, math.sqrt(gm / orb.p) * e * math.sin(theta), h / (r * r),
                     orb.mass])


def time_to_anomaly(orb: Orbit, theta_target: float, gm: float) -> float:
    """Time from the orbit's epoch to the (unwrapped) true anomaly theta_target."""
    e = orb.e
    E0, E1 = _ecc_anomaly(orb.theta, e), _ecc_anomaly(theta_target, e)
    return ((E1 - e * math.sin(E1)) - (E0 - e * math.sin(E0))) / mean_motion(orb, gm)


def next_apsis_time(orb: Orbit, kind: str, gm: float) -> float:
    """Time of the next perigee (kind='p') or apogee (kind='a') strictly after the orbit's epoch."""
    off = 0.0 if kind == "p" else math.pi
    k = math.floor((orb.theta - off) / TWO_PI) + 1
    return orb.t + time_to_anomaly(orb, off + TWO_PI * k, gm)


# --------------------------------------------------------------------------------------------
# Burns
# --------------------------------------------------------------------------------------------
@dataclass
class Burn:
    kind: str                 # 'p' (perigee) or 'a' (apogee)
    t_start: float
    duration: float
    x_start: np.ndarray
    x_end: np.ndarray
    orbit_before: Orbit
    orbit_after: Orbit
    sol: object = field(default=None, repr=False)

    @property
    def t_end(self) -> float:
        return self.t_start + self.duration


def _atol(p: GeoParams):
    return np.array([p.r0, 1.0, 1e3, 1e-3, p.m0]) * p.atol_scale


def integrate_burn(x0, t0, dt, p: GeoParams, dense=False):
    """Full-thrust arc, scipy Dormand-Prince 5(4)."""
    sol = solve_ivp(rhs, (t0, t0 + dt), np.asarray(x0, float), method="RK45", args=(p, p.thrust_n),
                    rtol=p.rtol, atol=_atol(p), dense_output=dense)
    if sol.status != 0:
        raise RuntimeError(f"burn integration failed: {sol.message}")
    return sol


def centred_burn(orb: Orbit, t_apsis: float, dt: float, kind: str, p: GeoParams, dense=False) -> Burn:
    """Coast back dt/2 from the apsis at t_apsis on ``orb``, burn dt at full thrust."""
    t0 = t_apsis - 0.5 * dt
    if t0 < orb.t - 1e-9:
        raise ValueError("burn would start before the end of the previous arc")
    x0 = state_at_time(orb, t0, p.gm)
    sol = integrate_burn(x0, t0, dt, p, dense)
    x1 = sol.y[:, -1]
    return Burn(kind, t0, dt, x0, x1, orb, osculating(x1, t0 + dt, p.gm), sol if dense else None)


def initial_orbit(p: GeoParams) -> Orbit:
    om = math.sqrt(p.gm / p.r0 ** 3)
    return osculating(np.array([p.r0, 0.0, 0.0, om, p.m0]), 0.0, p.gm)


def _first_apsis(orb: Orbit, kind: str, dt: float, p: GeoParams) -> float:
    """Centre time of the next burn: on the initial circular orbit every point is an apsis and the
    first burn starts at t0 (centre t0 + dt/2); otherwise the next apsis of the given kind."""
    if orb.e < 1e-12:
        return orb.t + 0.5 * dt
    return next_apsis_time(orb, kind, p.gm)


def run_series(orb: Orbit, kind: str, durations, p: GeoParams, dense=False) -> list[Burn]:
    burns = []
    for dt in durations:
        b = centred_burn(orb, _first_apsis(orb, kind, dt, p), dt, kind, p, dense)
        burns.append(b)
        orb = b.orbit_after
    return burns


def _apogee_miss(orb: Orbit, p: GeoParams) -> float:
    return (orb.r_apogee - p.r_target) / p.r_target


def _circ_miss(burn: Burn, p: GeoParams) -> float:
    """Eccentricity-vector component along the apogee direction of the orbit before the burn:
    -e before circularisation, 0 at it, > 0 after an overshoot."""
    ev = ecc_vector(burn.x_end, p.gm)
    ang = burn.orbit_before.psi + math.pi
    return float(ev[0] * math.cos(ang) + ev[1] * math.sin(ang))


def _series_with_trim(orb, kind, dt, n, p, miss, full=None):
    """n-1 burns of dt then one burn trimmed (brentq) so that miss(last burn) = 0. ``full`` are
    the n burns of dt if already computed (their first n-1 are reused).

    Returns the burns or None if the target is not reached with a full last burn, or is already
    passed before the last burn."""
    burns = list(full[:-1]) if full is not None else run_series(orb, kind, [dt] * (n - 1), p)
    o = burns[-1].orbit_after if burns else orb
    if burns and miss(burns[-1]) >= 0.0:
        return None

    def last(d):
        b = centred_burn(o, _first_apsis(o, kind, d, p), d, kind, p)
        return miss(b), b

    if full is None and last(dt)[0] < 0.0:
        return None
    lo = 1e-3
    if last(lo)[0] >= 0.0:
        return None
    d_last = brentq(lambda d: last(d)[0], lo, dt, xtol=1e-4, rtol=1e-12)
    return burns + [last(d_last)[1]]


def _miss_p(b, p):
    return _apogee_miss(b.orbit_after, p)


def _miss_a(b, p):
    return _circ_miss(b, p)


class _Escape(Exception):
    """An osculating orbit became parabolic/hyperbolic or the propellant ran out."""


def _guarded_series(orb, kind, durations, p):
    if sum(durations) * p.mass_flow_kg_s >= orb.mass:
        raise _Escape
    burns = []
    for dt in durations:
        b = centred_burn(orb, _first_apsis(orb, kind, dt, p), dt, kind, p)
        burns.append(b)
        orb = b.orbit_after
        if orb.e >= 0.99:
            raise _Escape
    return burns


def impulsive_estimate(orb: Orbit, kind: str, p: GeoParams) -> float:
    """Total burn time of the ideal (impulsive, Hohmann) manoeuvre of the series: a bracket
    centre for the root finder only."""
    c = p.thrust_n / p.mass_flow_kg_s
    if kind == "p":
        r = orb.r_perigee
        if orb.e <= 1e-9:
            dv = math.sqrt(p.gm / r) * (math.sqrt(2 * p.r_target / (r + p.r_target)) - 1.0)
        else:
            vp = math.sqrt(p.gm * orb.p) / r
            dv = math.sqrt(p.gm * (2 / r - 2 / (r + p.r_target))) - vp
    else:
        ra = orb.r_apogee
        dv = math.sqrt(p.gm / ra) - math.sqrt(p.gm * orb.p) / ra
    return orb.mass * (1.0 - math.exp(-max(dv, 1.0) / c)) / p.mass_flow_kg_s


def minimal_duration(orb: Orbit, kind: str, n: int, p: GeoParams, guess: float | None = None):
    """Smallest duration (multiple of duration_step_s) with which n equal burns reach the target;
    returns (dt_continuous, dt_rounded, the n burns of dt_rounded)."""
    miss = _miss_p if kind == "p" else _miss_a
    cache = {}

    def g(dt):
        try:
            bs = _guarded_series(orb, kind, [dt] * n, p)
        except _Escape:
            return 1.0
        cache[dt] = bs
        return miss(bs[-1], p)

    if guess is None:
        guess = impulsive_estimate(orb, kind, p) / n
    step = p.duration_step_s
    # walk over multiples of the step from the guess to the first one that reaches the target
    k = max(1, math.ceil(guess / step))
    gk = g(k * step)
    if gk >= 0.0:
        while k > 1:
            gm1 = g((k - 1) * step)
            if gm1 < 0.0:
                return _interp(k - 1, gm1, k, gk, step), k * step, cache.get(k * step)
            k, gk = k - 1, gm1
        raise RuntimeError(f"{kind} series n={n}: target reached with the shortest burn")
    for _ in range(100000):
        gp1 = g((k + 1) * step)
        if gp1 >= 0.0:
            return _interp(k, gk, k + 1, gp1, step), (k + 1) * step, cache.get((k + 1) * step)
        k, gk = k + 1, gp1
    raise RuntimeError(f"cannot bracket the {kind} burn duration for n={n}")


def _interp(k0, g0, k1, g1, step):
    """Continuous duration at which the miss crosses zero (linear interpolation, diagnostics)."""
    return step * (k0 + (k1 - k0) * (-g0) / (g1 - g0))


def trimmed_series(orb: Orbit, kind: str, n: int, p: GeoParams, guess=None):
    """n burns of the minimal rounded duration, the last trimmed to hit the target exactly."""
    miss = (lambda b: _miss_p(b, p)) if kind == "p" else (lambda b: _miss_a(b, p))
    dt_c, dt, full = minimal_duration(orb, kind, n, p, guess)
    burns = _series_with_trim(orb, kind, dt, n, p, miss, full)
    if burns is None:
        raise RuntimeError(f"trim failed for {kind} series n={n}, dt={dt}")
    return dt_c, dt, burns


# --------------------------------------------------------------------------------------------
# Schemes
# --------------------------------------------------------------------------------------------
@dataclass
class Scheme:
    name: str
    burns: list
    params: GeoParams
    dt_p_continuous: float = float("nan")
    dt_a_continuous: float = float("nan")

    @property
    def n_p(self):
        return sum(b.kind == "p" for b in self.burns)

    @property
    def n_a(self):
        return sum(b.kind == "a" for b in self.burns)

    @property
    def time_s(self):
        return self.burns[-1].t_end

    @property
    def fuel_kg(self):
        return self.params.m0 - self.burns[-1].x_end[4]

    def final_state(self):
        """State at t1 (Kepler coast on the final orbit; the transfer must end before t1 for this
        to be the vehicle's state, see ``feasible``)."""
        return state_at_time(self.burns[-1].orbit_after, self.params.t1, self.params.gm)

    @property
    def final_ecc(self):
        return self.burns[-1].orbit_after.e

    @property
    def rho_t1_miss_m(self):
        return float(self.final_state()[0] - self.params.r_target)

    def terminal_penalty_kg(self):
        p = self.params
        return p.lambda1 * self.final_ecc + p.lambda2 * self.rho_t1_miss_m ** 2

    def cost(self, lambda3=None):
        lam3 = self.params.lambda3 if lambda3 is None else lambda3
        return self.fuel_kg + self.terminal_penalty_kg() + lam3 * len(self.burns)

    def apse_rotations_deg(self, reference: str | None = None):
        """Apse-line rotation of every burn (deg), for one of the ``APSE_ROTATION_REFERENCES``
        (default: the config's ``numerics.apse_rotation_reference``):

        - ``burn_mid_time``: angle between the apse line of the osculating ellipse
          after the burn and the polar angle of the vehicle at the middle (in time) of the burn;
        - ``burn_mid_angle``: ... and the bisector of the burn arc (phi_start + phi_end)/2;
        - ``apsis``: ... and the apsis the burn was centred on, i.e. the apse line before the
          burn (psi_after - psi_before; for the first burn, on the circular orbit, the point of
          the unperturbed orbit at the burn's mid time).

        The apse line is a line: rotations are taken modulo 180 deg (an apogee burn that overshoots
        circularisation turns its apogee into the perigee). Burns whose ellipse after the burn has
        e < apse_rotation_min_ecc get NaN (no apse line)."""
        reference = self.params.apse_rotation_reference if reference is None else reference
        if reference not in APSE_ROTATION_REFERENCES:
            raise ValueError(f"unknown apse-rotation reference {reference!r}")
        p = self.params
        out = []
        for b in self.burns:
            if b.orbit_after.e < p.apse_rotation_min_ecc:
                out.append(float("nan"))
                continue
            if reference == "burn_mid_time":
                phi_c = integrate_burn(b.x_start, b.t_start, 0.5 * b.duration, p).y[1, -1]
            elif reference == "burn_mid_angle":
                phi_c = 0.5 * (b.x_start[1] + b.x_end[1])
            else:
                phi_c = state_at_time(b.orbit_before, b.t_start + 0.5 * b.duration, p.gm)[1]
            out.append(math.degrees((b.orbit_after.psi - phi_c + 0.5 * math.pi) % math.pi - 0.5 * math.pi))
        return out

    @property
    def max_apse_rotation_deg(self):
        r = [abs(v) for v in self.apse_rotations_deg() if math.isfinite(v)]
        return max(r) if r else float("nan")

    def durations(self, kind):
        return [b.duration for b in self.burns if b.kind == kind]

    def summary(self) -> dict:
        p = self.params
        return {
            "scheme": self.name, "burns": len(self.burns), "perigee_burns": self.n_p,
            "perigee_burn_s": self.durations("p"), "apogee_burns": self.n_a,
            "apogee_burn_s": self.durations("a"), "time_s": self.time_s, "fuel_kg": self.fuel_kg,
            "starts_penalty_kg": p.lambda3 * len(self.burns),
            "fuel_with_penalty_kg": self.fuel_kg + p.lambda3 * len(self.burns),
            "terminal_penalty_kg": self.terminal_penalty_kg(), "cost_I_lambda_kg": self.cost(),
            "final_ecc": self.final_ecc, "rho_t1_miss_m": self.rho_t1_miss_m,
            "max_apse_rotation_deg": self.max_apse_rotation_deg,
            "apse_rotation_deg": self.apse_rotations_deg(),
            "dt_p_continuous_s": self.dt_p_continuous, "dt_a_continuous_s": self.dt_a_continuous,
            "mass_flow_kg_s": p.mass_flow_kg_s, "feasible": self.time_s <= p.t1,
        }


def optimised_scheme(n_p: int, n_a: int, p: GeoParams, name="scheme", guess_p=None, guess_a=None,
                     perigee=None) -> Scheme:
    """The (n_p, n_a) scheme of the approximate method (durations chosen as described above)."""
    if perigee is None:
        perigee = trimmed_series(initial_orbit(p), "p", n_p, p, guess_p)
    dtc_p, _, pb = perigee
    dtc_a, _, ab = trimmed_series(pb[-1].orbit_after, "a", n_a, p, guess_a)
    return Scheme(name, pb + ab, p, dtc_p, dtc_a)


def fixed_scheme(perigee_s, apogee_s, p: GeoParams, name="flown") -> Scheme:
    """A scheme with given burn durations (the flown Breeze-M scheme)."""
    pb = run_series(initial_orbit(p), "p", perigee_s, p)
    ab = run_series(pb[-1].orbit_after, "a", apogee_s, p)
    return Scheme(name, pb + ab, p)


def scheme_grid(p: GeoParams, n_p_range, n_a_range, progress=None) -> list[dict]:
    """Evaluate every (n_p, n_a) scheme in the ranges; stop increasing n_a once the transfer time
    exceeds t1 (it grows with n_a). Returns one record per scheme (with the Scheme object)."""
    rows = []
    gp = None
    for n_p in range(n_p_range[0], n_p_range[1] + 1):
        perigee = trimmed_series(initial_orbit(p), "p", n_p, p, gp)
        gp = perigee[0] * n_p / (n_p + 1)
        ga = None
        for n_a in range(n_a_range[0], n_a_range[1] + 1):
            sch = optimised_scheme(n_p, n_a, p, f"np{n_p}_na{n_a}", guess_a=ga, perigee=perigee)
            ga = sch.dt_a_continuous * n_a / (n_a + 1)
            rows.append({"n_p": n_p, "n_a": n_a, "time_s": sch.time_s, "fuel_kg": sch.fuel_kg,
                         "terminal_penalty_kg": sch.terminal_penalty_kg(),
                         "feasible": sch.time_s <= p.t1, "scheme": sch})
            if progress:
                progress(n_p, n_a, sch)
            if sch.time_s > p.t1:
                break
    return rows


def best_scheme(rows, lambda3: float) -> dict:
    feas = [r for r in rows if r["feasible"]]
    if not feas:
        raise RuntimeError("no scheme of the grid reaches GEO before t1")
    return min(feas, key=lambda r: r["fuel_kg"] + r["terminal_penalty_kg"] + lambda3 * (r["n_p"] + r["n_a"]))


# --------------------------------------------------------------------------------------------
# Readings of the published transfer time and burn counts (hypothesis tests, spec D1)
# --------------------------------------------------------------------------------------------
def orbital_period(orb: Orbit, gm: float) -> float:
    return TWO_PI / mean_motion(orb, gm)


# name -> (description, supported by the spec's text?)
TIME_BOOKKEEPINGS = {
    "apsis_arcs": ("exact Kepler arcs from the end of a burn to dt/2 before the next apsis of the "
                   "series' kind, transfer time = end of the last burn (the spec's method)", True),
    "whole_periods": ("every burn-to-burn interval (centre to centre) is a whole revolution of the "
                      "orbit after the burn, the perigee-to-apogee transfer arc included", False),
    "plus_final_revolution": ("apsis_arcs + one revolution of the final (GEO) orbit", False),
    "plus_initial_revolution": ("apsis_arcs + one revolution of the initial LEO before the first "
                                "burn (phi = 0 taken as the apsis to reach)", False),
    "whole_periods_plus_initial_and_final": ("whole_periods + one LEO and one final revolution", False),
    "late_first_apogee_plus_final": ("apsis_arcs + one extra revolution of the transfer ellipse "
                                     "before the first apogee burn + one final revolution "
                                     "(ad hoc combination, the closest found)", False),
}


def time_variants(s: Scheme) -> dict:
    """Transfer time of a scheme under every ``TIME_BOOKKEEPINGS`` reading (s)."""
    p = s.params
    B = s.burns
    T = [orbital_period(b.orbit_after, p.gm) for b in B]
    t_leo = orbital_period(initial_orbit(p), p.gm)
    base = s.time_s
    whole = 0.5 * B[0].duration + sum(T[:-1]) + 0.5 * B[-1].duration
    k_tr = next((i for i in range(len(B) - 1) if B[i].kind != B[i + 1].kind), None)
    t_tr = T[k_tr] if k_tr is not None else 0.0
    return {"apsis_arcs": base, "whole_periods": whole, "plus_final_revolution": base + T[-1],
            "plus_initial_revolution": base + t_leo,
            "whole_periods_plus_initial_and_final": whole + t_leo + T[-1],
            "late_first_apogee_plus_final": base + t_tr + T[-1]}


def _select(rows, key, feasible=None):
    feas = [r for r in rows if (feasible(r) if feasible else r["feasible"])]
    return min(feas, key=key) if feas else None


def hypothesis_table(res: dict, cfg: dict, target: dict) -> list[dict]:
    """Readings of the source tested against the published classical scheme (spec D1).

    ``target``: published ``n_p``, ``n_a``, ``time_s``, ``fuel_kg``, ``max_apse_rotation_deg``,
    ``perigee_burn_s``, ``apogee_burn_s`` (read by the caller from config/published). Every row:
    the reading, whether the spec's text supports it, the (n_p, n_a) it selects or is evaluated
    at, its time, fuel, rotation, and whether it reproduces the published numbers."""
    p = res["params"]
    rows_grid = res["rows"]
    pc = res["schemes"].get("classical_published_counts")
    n_p0, n_a0 = target["n_p"], target["n_a"]
    np_max, na_max = max(r["n_p"] for r in rows_grid), max(r["n_a"] for r in rows_grid)
    out = []

    def rec(h, reading, supported, s, time_s=None, counts_selected=True, note=""):
        t = s.time_s if time_s is None else time_s
        counts_ok = (s.n_p, s.n_a) == (n_p0, n_a0)
        time_ok = abs(t - target["time_s"]) <= 0.001 * target["time_s"]
        dp, da = s.durations("p"), s.durations("a")
        if counts_selected and (s.n_p == np_max or s.n_a == na_max):
            note = "; ".join(x for x in (note, "optimum at the search-range edge") if x)
        out.append({
            "hypothesis": h, "reading": reading, "spec_support": "yes" if supported else "no",
            "counts": "selected" if counts_selected else "imposed (published)",
            "mass_flow_kg_s": s.params.mass_flow_kg_s, "perigee_burns": s.n_p, "apogee_burns": s.n_a,
            "perigee_burn_s": f"{dp[0]:.1f}..{dp[-1]:.1f}", "apogee_burn_s": f"{da[0]:.1f}..{da[-1]:.1f}",
            "time_s": t, "time_minus_published_s": t - target["time_s"], "fuel_kg": s.fuel_kg,
            "max_apse_rotation_deg": s.max_apse_rotation_deg,
            "reproduces": ("+".join(w for w, ok in (("counts", counts_ok and counts_selected),
                                                    ("time", time_ok)) if ok) or "no"),
            "note": note})

    cost = lambda r: r["fuel_kg"] + r["terminal_penalty_kg"]  # noqa: E731
    # H0: the spec's reading
    b = _select(rows_grid, cost)
    rec("H0_spec", "apsis arcs, count by t1, cost fuel + terminal penalties", True, b["scheme"],
        note="the reported classical scheme")
    if pc is not None:
        rec("H0_spec_published_counts", "apsis arcs at the published counts", True, pc, counts_selected=False,
            note=f"t1 - time = {p.t1 - pc.time_s:.0f} s unused; equal continuous durations "
                 f"{pc.dt_p_continuous:.2f} s / {pc.dt_a_continuous:.2f} s (untrimmed reading)")
    # H1: count selection rules with the spec's time
    b = _select(rows_grid, lambda r: r["fuel_kg"])
    rec("H1_fuel_only", "count by t1, cost fuel only (terminal penalties ignored: the last burns are "
        "trimmed to hit the target)", True, b["scheme"])
    n_tot = n_p0 + n_a0
    b = _select(rows_grid, cost, lambda r: r["feasible"] and r["n_p"] + r["n_a"] == n_tot)
    if b is not None:
        rec("H1_total_fixed", f"total number of burns fixed at the published {n_tot}, best split", False,
            b["scheme"])
    # H2: time bookkeepings (at the published counts, and the count each one selects)
    tv = {id(r["scheme"]): time_variants(r["scheme"]) for r in rows_grid}
    for name, (desc, supported) in TIME_BOOKKEEPINGS.items():
        if name == "apsis_arcs":
            continue
        if pc is not None:
            rec(f"H2_{name}_published_counts", desc, supported, pc, time_s=time_variants(pc)[name],
                counts_selected=False)
        b = _select(rows_grid, cost, lambda r, n=name: tv[id(r["scheme"])][n] <= p.t1)
        if b is not None:
            rec(f"H2_{name}", desc + "; count by t1 under this time", supported, b["scheme"],
                time_s=tv[id(b["scheme"])][name])
    # H3: mass flow readings (the spec names the ambiguity)
    for fl, r3 in res.get("flow_grids", {}).items():
        b = _select(r3, cost)
        rec(f"H3_flow_{fl:g}", f"mass flow {fl:g} kg/s, count by t1", True, b["scheme"])
    for sch in res["sensitivity_schemes"]:
        if sch.name == "classical_published_counts" and sch.params.mass_flow_kg_s != p.mass_flow_kg_s:
            rec(f"H3_flow_{sch.params.mass_flow_kg_s:g}_published_counts",
                f"mass flow {sch.params.mass_flow_kg_s:g} kg/s at the published counts", True, sch,
                counts_selected=False)
    m = cfg["model"]
    c_lit = 1.0 / 3.07e-3
    out.append({k: "" for k in out[0]} | {
        "hypothesis": "H3_flow_literal_mu", "reading": "mu = 3.07e-3 s/m as printed "
        f"(mass flow {3.07e-3 * float(m['thrust_max_n']):g} kg/s)", "spec_support": "yes",
        "reproduces": "no",
        "note": f"exhaust velocity 1/mu = {c_lit:.0f} m/s: the whole propellant load gives at most "
                f"{c_lit * math.log(p.m0 / (p.m0 - target['fuel_kg'])):.0f} m/s for the published fuel, "
                f"far below the ~3.9 km/s LEO-GEO delta-v; GEO is unreachable"})
    # H4: apse-rotation definitions at the published counts
    if pc is not None:
        for ref in APSE_ROTATION_REFERENCES:
            rot = [abs(v) for v in pc.apse_rotations_deg(ref) if math.isfinite(v)]
            out.append({k: "" for k in out[0]} | {
                "hypothesis": f"H4_rotation_{ref}", "reading": f"apse rotation per burn relative to {ref}",
                "spec_support": "yes" if ref == "apsis" else "no",
                "counts": "imposed (published)", "perigee_burns": pc.n_p, "apogee_burns": pc.n_a,
                "max_apse_rotation_deg": max(rot),
                "reproduces": "rotation" if abs(max(rot) - target["max_apse_rotation_deg"])
                <= 0.05 * target["max_apse_rotation_deg"] else "no",
                "note": f"sum over burns {sum(rot):.3f} deg"})
    return out


HYPOTHESIS_COLUMNS = ["hypothesis", "reading", "spec_support", "counts", "mass_flow_kg_s",
                      "perigee_burns", "apogee_burns", "perigee_burn_s", "apogee_burn_s", "time_s",
                      "time_minus_published_s", "fuel_kg", "max_apse_rotation_deg", "reproduces", "note"]


# --------------------------------------------------------------------------------------------
# Sampling and switching function
# --------------------------------------------------------------------------------------------
def segments(s: Scheme):
    """(t_a, t_b, x_a, u) of every arc from 0 to t1: coasts (u = 0) and burns (u = U_max)."""
    p = s.params
    segs = []
    t, orb = 0.0, initial_orbit(p)
    for b in s.burns:
        if b.t_start > t + 1e-9:
            segs.append((t, b.t_start, state_at_time(orb, t, p.gm), 0.0))
        segs.append((b.t_start, b.t_end, b.x_start, p.thrust_n))
        t, orb = b.t_end, b.orbit_after
    if p.t1 > t:
        segs.append((t, p.t1, state_at_time(orb, t, p.gm), 0.0))
    return segs


def sample_orbits(s: Scheme, n_per_orbit=361):
    """Plane curves (km) of the initial orbit, the osculating ellipse after every burn, and the
    burn arcs, for the orbit-sequence plot."""
    p = s.params
    th = np.linspace(0, TWO_PI, n_per_orbit)
    ellipses = []
    for orb in [initial_orbit(p)] + [b.orbit_after for b in s.burns]:
        r = orb.p / (1 + orb.e * np.cos(th))
        ellipses.append(np.stack([r * np.cos(th + orb.psi), r * np.sin(th + orb.psi)]) / 1e3)
    arcs = []
    for b in s.burns:
        sol = integrate_burn(b.x_start, b.t_start, b.duration, p, dense=True)
        tt = np.linspace(b.t_start, b.t_end, 40)
        y = sol.sol(tt)
        arcs.append((b.kind, np.stack([y[0] * np.cos(y[1]), y[0] * np.sin(y[1])]) / 1e3))
    return ellipses, arcs


@functools.lru_cache(maxsize=8)
def _jax_adjoint(p: GeoParams):
    import jax
    import jax.numpy as jnp

    def f(x, u):
        rho, v, om, m = x[0], x[2], x[3], x[4]
        s = jnp.sqrt(v * v + rho * rho * om * om)
        a = u / (m * s)
        return jnp.stack([v, om, rho * om * om - p.gm / rho ** 2 + a * v,
                          -2.0 * v * om / rho + a * om, -p.mu * u])

    jac = jax.jacfwd(f, argnums=0)

    @jax.jit
    def full(y, u):
        x = y[:5]
        P = y[5:].reshape(5, -1)
        return jnp.concatenate([f(x, u), (-jac(x, u).T @ P).ravel()])

    ecc_jac = jax.jit(jax.jacfwd(lambda x: ecc_vector(x, p.gm, jnp)))
    return full, ecc_jac


def switching_function(s: Scheme, samples_per_arc=60, sample_dt_s=500.0):
    """k(t) along the scheme (see module docstring). Returns a dict with t, k, the burn mask,
    the fitted (nu, xi), and check statistics."""
    p = s.params
    full, ecc_jac = _jax_adjoint(p)
    segs = segments(s)
    xT = state_at_time(s.burns[-1].orbit_after, p.t1, p.gm)
    J = np.asarray(ecc_jac(xT))                       # 2 x 5
    basis = np.zeros((5, 3))
    basis[0, 0] = -1.0                                # nu: rho multiplier
    basis[:, 1] = -p.lambda1 * J[0]
    basis[:, 2] = -p.lambda1 * J[1]
    basis[4, :] = 0.0                                 # psi5(t1) = 0 (mass free)
    P = basis.copy()
    ts, ks, on, sw_rows, state_gap = [], [], [], [], 0.0

    def kvec(y):
        x = y[:5]
        P_ = y[5:].reshape(5, 3)
        rho, v, om, m = x[0], x[2], x[3], x[4]
        s_ = math.sqrt(v * v + rho * rho * om * om)
        return (v * P_[2] + om * P_[3]) / (p.mu * m * s_) - P_[4]

    x_next_start = None
    for (ta, tb, xa, u) in reversed(segs):
        if u:
            sol_f = integrate_burn(xa, ta, tb - ta, p)
            xb = sol_f.y[:, -1]
        else:
            xb = state_at_time(osculating(xa, ta, p.gm), tb, p.gm)
        if x_next_start is not None:
            state_gap = max(state_gap, abs(xb[0] - x_next_start[0]) / xb[0])
        y0 = np.concatenate([xb, P.ravel()])
        te = np.linspace(tb, ta, max(samples_per_arc, int(math.ceil((tb - ta) / sample_dt_s)) + 1))
        sol = solve_ivp(lambda t, y: np.asarray(full(y, u)), (tb, ta), y0, method="RK45",
                        t_eval=te, rtol=p.rtol, atol=np.concatenate([_atol(p), np.full(15, 1e-12)]))
        if sol.status != 0:
            raise RuntimeError(f"costate integration failed: {sol.message}")
        P = sol.y[5:, -1].reshape(5, 3)
        for j in range(sol.y.shape[1]):
            ts.append(sol.t[j])
            ks.append(kvec(sol.y[:, j]))
            on.append(bool(u))
        if u:
            sw_rows.append(kvec(sol.y[:, 0]))
            sw_rows.append(kvec(sol.y[:, -1]))
        x_next_start = xa
    ts = np.array(ts[::-1])
    K = np.array(ks[::-1])
    on = np.array(on[::-1])
    A = np.array(sw_rows)
    coef, *_ = np.linalg.lstsq(A, np.ones(len(A)), rcond=None)
    k = K @ coef
    order = np.argsort(ts, kind="stable")
    ts, k, on = ts[order], k[order], on[order]
    xi = float(np.hypot(coef[1], coef[2]))
    inner_on = on.copy()
    return {
        "t": ts, "k": k, "burn": on, "nu": float(coef[0]), "xi": coef[1:].tolist(), "xi_norm": xi,
        "rho_miss_implied_m": float(coef[0] / (2 * p.lambda2)) if p.lambda2 > 0 else float("nan"),
        "switch_residual_max": float(np.max(np.abs(A @ coef - 1.0))),
        "frac_burn_k_ge_1": float(np.mean(k[inner_on] >= 1.0 - 1e-6)) if inner_on.any() else float("nan"),
        "frac_coast_k_lt_1": float(np.mean(k[~on] < 1.0 + 1e-6)),
        "k_min_on_burns": float(np.min(k[on])), "k_max_on_coasts": float(np.max(k[~on])),
        "backward_state_gap_rel": state_gap,
    }


# --------------------------------------------------------------------------------------------
# The study: three schemes, mass-flow sensitivity, switching-function checks
# --------------------------------------------------------------------------------------------
def _range(cfg, key):
    r = cfg.get("search", {}).get(key)
    if (not isinstance(r, (list, tuple)) or len(r) != 2 or not all(isinstance(v, int) for v in r)
            or r[0] < 1 or r[1] < r[0]):
        raise ConfigError(f"geo_burns.search.{key}", r, "must be [min, max] integers, 1 <= min <= max")
    return tuple(r)


def _durations(cfg, key):
    v = cfg.get("flown", {}).get(key)
    if not isinstance(v, (list, tuple)) or not v or not all(
            isinstance(d, (int, float)) and math.isfinite(d) and d > 0 for d in v):
        raise ConfigError(f"geo_burns.flown.{key}", v, "must be a non-empty list of durations > 0 s")
    return [float(d) for d in v]


def scheme_record(s: Scheme, lambda3: float) -> dict:
    """One row of the scheme table (fuel with the start penalty uses ``lambda3``)."""
    d = s.summary()
    d["starts_penalty_kg"] = lambda3 * len(s.burns)
    d["fuel_with_penalty_kg"] = s.fuel_kg + lambda3 * len(s.burns)
    d["cost_I_lambda_kg"] = s.cost(lambda3)
    return d


def run_study(cfg: dict, published_counts: tuple[int, int] | None = None, progress=None) -> dict:
    """D1 end to end. ``published_counts`` = (n_p, n_a) of the published classical scheme: the
    approximate method is also evaluated at that structure, so that its durations, fuel and time
    can be compared whatever number of burns our own optimisation selects."""
    p = params_from_config(cfg)
    lam3 = p.lambda3
    flown_flow = _positive(cfg.get("flown", {}), "mass_flow_kg_s", "geo_burns.flown")
    pflown = params_from_config(cfg, mass_flow_kg_s=flown_flow)
    rp, ra = _range(cfg, "perigee_burns"), _range(cfg, "apogee_burns")
    rows = scheme_grid(p, rp, ra, progress)
    best0, best3 = best_scheme(rows, 0.0), best_scheme(rows, lam3)
    schemes = {"classical": best0["scheme"], "start_penalised": best3["scheme"]}
    schemes["classical"].name, schemes["start_penalised"].name = "classical", "start_penalised"
    schemes["flown"] = fixed_scheme(_durations(cfg, "perigee_burn_s"), _durations(cfg, "apogee_burn_s"),
                                    pflown, "flown")
    if published_counts is not None:
        schemes["classical_published_counts"] = optimised_scheme(*published_counts, p,
                                                                 "classical_published_counts")
    edge = {name: (s.n_p == rp[1] or s.n_a == ra[1]) for name, s in schemes.items()
            if name in ("classical", "start_penalised")}
    # mass-flow sensitivity: same burn counts, durations re-chosen (flown: same durations)
    sens, sens_schemes, flow_grids = [], [], {}
    raw = cfg.get("model", {}).get("mass_flow_sensitivity_kg_s", [])
    try:
        flows = [float(f) for f in raw]
    except (TypeError, ValueError):
        raise ConfigError("geo_burns.model.mass_flow_sensitivity_kg_s", raw, "must be a list of numbers") from None
    for fl in flows:
        if not (math.isfinite(fl) and fl > 0):
            raise ConfigError("geo_burns.model.mass_flow_sensitivity_kg_s", fl, "must be > 0")
        pf = params_from_config(cfg, mass_flow_kg_s=fl)
        if pf != p:                                  # the count each flow selects (hypothesis H3)
            flow_grids[fl] = scheme_grid(pf, rp, ra)
        for name, s in schemes.items():
            if s.params == pf:                       # already computed at this flow
                s2 = s
            elif name == "flown":
                s2 = fixed_scheme(s.durations("p"), s.durations("a"), pf, name)
            else:
                s2 = optimised_scheme(s.n_p, s.n_a, pf, name)
            sens.append(scheme_record(s2, lam3))
            sens_schemes.append(s2)
    grid = [{k: v for k, v in r.items() if k != "scheme"} for r in rows]
    for r in grid:
        r["cost_classical_kg"] = r["fuel_kg"] + r["terminal_penalty_kg"]
        r["cost_penalised_kg"] = r["cost_classical_kg"] + lam3 * (r["n_p"] + r["n_a"])
    return {"params": p, "schemes": schemes, "grid": grid, "sensitivity": sens, "rows": rows,
            "flow_grids": flow_grids, "sensitivity_schemes": sens_schemes,
            "records": {n: scheme_record(s, lam3) for n, s in schemes.items()},
            "optimum_at_search_edge": edge, "lambda3": lam3}


GEO_CSV_COLUMNS = ["scheme", "burns", "perigee_burns", "perigee_burn_s", "apogee_burns",
                   "apogee_burn_s", "time_s", "fuel_kg", "fuel_with_penalty_kg",
                   "max_apse_rotation_deg"]


def csv_row(rec: dict) -> dict:
    """A geo_burns.csv row: burn-duration lists as 'd1;d2;...' in seconds (3 decimals)."""
    row = {k: rec[k] for k in GEO_CSV_COLUMNS}
    for k in ("perigee_burn_s", "apogee_burn_s"):
        row[k] = ";".join(f"{d:.3f}" for d in rec[k])
    return row


# --------------------------------------------------------------------------------------------
# Figures (returned, saved by the caller)
# --------------------------------------------------------------------------------------------
def plot_orbit_sequence(s: Scheme, title: str | None = None):
    import matplotlib.pyplot as plt

    ellipses, arcs = sample_orbits(s)
    fig, ax = plt.subplots(figsize=(6.4, 6.4))
    th = np.linspace(0, TWO_PI, 361)
    r_e = 6378.137
    ax.fill(r_e * np.cos(th), r_e * np.sin(th), color="0.85", zorder=0, label="Earth")
    gr = s.params.r_target / 1e3
    ax.plot(gr * np.cos(th), gr * np.sin(th), "k--", lw=0.6, label="GEO radius")
    for i, xy in enumerate(ellipses):
        ax.plot(xy[0], xy[1], lw=0.6, color=plt.cm.viridis(i / max(1, len(ellipses) - 1)))
    for j, (kind, xy) in enumerate(arcs):
        ax.plot(xy[0], xy[1], lw=2.5, color="tab:red" if kind == "p" else "tab:orange",
                label=("perigee burns" if kind == "p" else "apogee burns")
                if j == next(i for i, a in enumerate(arcs) if a[0] == kind) else None)
    ax.set_aspect("equal")
    ax.set_xlabel("x, km")
    ax.set_ylabel("y, km")
    ax.set_title(title or f"{s.name}: {s.n_p} perigee + {s.n_a} apogee burns, "
                 f"fuel {s.fuel_kg:.0f} kg")
    ax.legend(loc="lower left", fontsize=7)
    ax.grid(alpha=0.3)
    return fig


def plot_switching(sw: dict, title: str):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(9, 6))
    t, k, on = sw["t"], sw["k"], sw["burn"]
    for ax, mask in zip(axes, (np.ones_like(on), t <= sw.get("zoom_s", 1.0e5))):
        ax.plot(t[mask] / 1e3, k[mask], "-", lw=0.8, color="tab:blue", label="k(t)")
        ax.plot(t[mask & on] / 1e3, k[mask & on], ".", ms=3, color="tab:red", label="burn (u = U_max)")
        ax.axhline(1.0, color="k", lw=0.7)
        ax.set_ylabel("k(t)")
        ax.grid(alpha=0.3)
    axes[0].set_title(title)
    axes[1].set_xlabel("t, 1000 s")
    axes[1].set_title(f"first {sw.get('zoom_s', 1.0e5) / 1e3:.0f} 000 s", fontsize=9)
    axes[0].legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    return fig
