"""Perturbing accelerations for near-Earth problems: EGM96 geopotential (<= 4x4), J2, Moon, Sun.

Source: spec/01-methods.md §1.7 (computation chain steps 3-5) and spec/02-multirev.md §1
("Perturbation model", "Earth constants") and Appendix B. Everything here is pure ``jax.numpy``,
jit-able and differentiable (grad, jvp, jacfwd, forward-over-reverse) in float64.

Conventions: r is the geocentric position [m] in ICRS (EME2000) axes; t is seconds TDB past
J2000 (JD 2451545.0 TDB), see :mod:`spaceopt.ephemeris`; accelerations are in m/s^2, ICRS axes.
The central term mu/r^2 is *not* included (the solver owns it, with its own mu).

Geopotential (perturbing part, n >= 2), in ITRS Cartesian coordinates (x, y, z), r = |r|:
    U(r) = GM sum_{n=2}^{N} sum_{m=0}^{min(n,M)} (a_e^n / r^{n+1}) Pbar_nm(sin phi)
                                               (Cbar_nm cos m lam + Sbar_nm sin m lam).
It is written without angles (no pole singularity, smooth for AD): with u = z/r,
Pbar_nm = N_nm P_nm, P_nm(u) = (1-u^2)^{m/2} A_nm(u), A_nm = d^m P_n/du^m, and
cos^m phi (cos m lam, sin m lam) = (Re, Im)((x + i y)^m) / r^m, so
    U = GM sum N_nm a_e^n A_nm(z/r) (Cbar_nm c_m + Sbar_nm s_m) / r^{n+m+1},
    c_m + i s_m = (x + i y)^m  (c_m = x c_{m-1} - y s_{m-1}, s_m = x s_{m-1} + y c_{m-1}),
    A_mm = (2m-1)!!,  A_{m+1,m} = (2m+1) u A_mm,
    (n-m) A_nm = (2n-1) u A_{n-1,m} - (n+m-1) A_{n-2,m}          (Legendre recursion),
    N_nm = sqrt((2 - delta_m0)(2n+1)(n-m)!/(n+m)!)                 (full normalization).
The acceleration is a = grad U by ``jax.grad`` (no hand derivative, design.md principle 1).
In ICRS: a = M(t)^T grad U(M(t) r) with M(t) from :mod:`spaceopt.frames` (frozen NPB, Earth
angle ERA by default). Coefficients, GM = 3.986004415e14 m^3/s^2 and a_e = 6378136.3 m come
from ``data/egm96_4x4.yaml`` (NASA/TP-1998-206861; spec/02-multirev.md Appendix B), where the
independent check of the values is documented.

J2 only (lunar chapter, spec/01-methods.md §1.7, thesis §5.1.1):
    a_J2 = (3/2) mu J2 Re^2 / r^5 ((5 z^2/r^2 - 1) x, (5 z^2/r^2 - 1) y, (5 z^2/r^2 - 3) z)
in the Earth-fixed frame (pole = frozen CIP of t0, like the geopotential); being axisymmetric it
is evaluated in ICRS about that pole, with no Earth rotation angle (``j2_acceleration(pole=)``).
ERRATUM: the thesis prints a factor 1/2 instead of 3/2 and a z-component 5(z^2/r^2 - 3) z; the
formula above is the gradient of U_J2 = -mu J2 Re^2 (3 z^2/r^2 - 1)/(2 r^3) (checked in the tests against jax.grad
and against the 4x4 model restricted to C20). The thesis does not give J2, Re or mu; this module
uses the EGM96 values J2 = -sqrt(5) Cbar_20 = 1.0826266835531513e-3, Re = a_e, mu = GM(EGM96).

Third bodies (thesis eq. 5.1.1.1), l in {Moon, Sun}, positions from DE405
(:class:`spaceopt.ephemeris.ChebyshevEphemeris`):
    a_l = mu_l ((r_l - r)/|r_l - r|^3 - r_l/|r_l|^3),
mu_Sun = 1.32712440018e20, mu_Moon = 4.902799e12 m^3/s^2 (thesis §4 intro; constants.py).

Model configuration (``build_model``)::

    {"geopotential": {"degree": 4, "order": 4} | "j2" | None,
     "third_bodies": ["moon", "sun"],          # any subset, or [] / None
     "earth_angle": "era" | "gast",            # optional, default "era"
     "ut1_minus_utc": 0.0}                     # optional, seconds, default 0
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import yaml

from .constants import MU_MOON, MU_SUN
from .ephemeris import ChebyshevEphemeris, load_ephemeris
from .errors import ConfigError
from .frames import EarthRotation, earth_angle, earth_rotation, to_icrs, to_itrs

EGM96_FILE = Path(__file__).parent / "data" / "egm96_4x4.yaml"
MAX_DEGREE = 4
THIRD_BODY_MU = {"moon": MU_MOON, "sun": MU_SUN}      # m^3/s^2 (thesis values)
MODEL_KEYS = ("geopotential", "third_bodies", "earth_angle", "ut1_minus_utc")


# --------------------------------------------------------------------------------------------
# Coefficients
# --------------------------------------------------------------------------------------------
@lru_cache(maxsize=None)
def _egm96_cached():
    data = yaml.safe_load(EGM96_FILE.read_text())
    nmax = int(data["max_degree"])
    C = np.zeros((nmax + 1, nmax + 1))
    S = np.zeros((nmax + 1, nmax + 1))
    for n, m, c, s in data["coefficients"]:
        C[int(n), int(m)] = float(c)
        S[int(n), int(m)] = float(s)
    C.setflags(write=False); S.setflags(write=False)
    return float(data["gm"]), float(data["radius"]), C, S


def load_egm96() -> dict:
    """EGM96 (<= 4x4): ``gm`` [m^3/s^2], ``radius`` [m], ``C``, ``S`` (5x5, fully normalized),
    ``j2`` = -sqrt(5) C20 (unnormalized)."""
    gm, radius, C, S = _egm96_cached()
    return {"gm": gm, "radius": radius, "C": C.copy(), "S": S.copy(), "j2": -math.sqrt(5.0) * C[2, 0]}


def _norm(n: int, m: int) -> float:
    return math.sqrt((2 - (m == 0)) * (2 * n + 1) * math.factorial(n - m) / math.factorial(n + m))


# --------------------------------------------------------------------------------------------
# Geopotential (Earth-fixed frame)
# --------------------------------------------------------------------------------------------
def geopotential(r_itrs, C, S, gm, radius, degree: int = 4, order: int = 4):
    """Perturbing geopotential U [m^2/s^2] (degrees 2..degree, orders 0..min(n, order)).

    r_itrs: (3,) Earth-fixed position [m]; C, S: fully normalized coefficients, square arrays of
    size >= degree+1. With numpy C, S (the normal case) the coefficients are compile-time
    constants and zero terms (S_n0, ...) are skipped; jax arrays also work (traced).
    degree, order: static Python ints. Formula and recursion: module docstring, evaluated on the
    unit vector (x, y, z)/r (one rsqrt, no division in the traced code; the recursion ratios
    (2n-1)/(n-m), (n+m-1)/(n-m) and N_nm C_nm are folded into Python constants):
        U = (GM/r) sum_n (a_e/r)^n sum_m N_nm A_nm(u) (C_nm c_m + S_nm s_m),
        c_m + i s_m = ((x + i y)/r)^m.

    Why scalar code and not a vectorized form: this function is differentiated three times by
    the solver (field -> sensitivities). A dense-polynomial variant (monomial cube contracted with
    a coefficient tensor) compiled slower and ran ~15x slower on CPU than this unrolled scalar
    recursion, which XLA fuses into few kernels.
    """
    static = isinstance(C, np.ndarray) and isinstance(S, np.ndarray)
    x, y, z = r_itrs[0], r_itrs[1], r_itrs[2]
    inv_r = jax.lax.rsqrt(x * x + y * y + z * z)
    xh, yh, u = x * inv_r, y * inv_r, z * inv_r
    cm, sm = [None, xh], [None, yh]                            # ((x + i y)/r)^m, m >= 1
    for m in range(2, order + 1):
        cm.append(xh * cm[m - 1] - yh * sm[m - 1])
        sm.append(xh * sm[m - 1] + yh * cm[m - 1])
    A = {}                                                     # A_nm(u) = d^m P_n / du^m
    for m in range(0, order + 1):
        A[(m, m)] = float(math.prod(range(1, 2 * m, 2)))      # (2m-1)!!, a constant
        if m + 1 <= degree:
            A[(m + 1, m)] = ((2 * m + 1) * A[(m, m)]) * u
        for n in range(m + 2, degree + 1):
            A[(n, m)] = (((2 * n - 1) / (n - m)) * u * A[(n - 1, m)]
                         - ((n + m - 1) / (n - m)) * A[(n - 2, m)])
    total = 0.0
    ar = radius * inv_r
    arn = ar
    for n in range(2, degree + 1):
        arn = arn * ar                                         # (a_e / r)^n
        inner = 0.0
        for m in range(0, min(n, order) + 1):
            cnm, snm = C[n, m], S[n, m]
            if static:
                cnm, snm = float(cnm), float(snm)
                if cnm == 0.0 and snm == 0.0:
                    continue
            nrm = _norm(n, m)
            if m == 0:
                term = nrm * cnm
            elif static and snm == 0.0:
                term = (nrm * cnm) * cm[m]
            elif static and cnm == 0.0:
                term = (nrm * snm) * sm[m]
            else:
                term = (nrm * cnm) * cm[m] + (nrm * snm) * sm[m]
            inner = inner + term * A[(n, m)]
        total = total + arn * inner
    return gm * inv_r * total


def geopotential_acceleration(r_itrs, C, S, gm, radius, degree: int = 4, order: int = 4):
    """grad U [m/s^2] in the Earth-fixed frame, by ``jax.grad`` of :func:`geopotential`."""
    return jax.grad(geopotential)(jnp.asarray(r_itrs, dtype=jnp.float64), C, S, gm, radius, degree, order)


def j2_potential(r, mu, j2, radius):
    """U_J2 = -mu J2 Re^2 (3 z^2/r^2 - 1) / (2 r^3) [m^2/s^2] (Earth-fixed frame)."""
    r2 = jnp.dot(r, r)
    rn = jnp.sqrt(r2)
    return -mu * j2 * radius ** 2 * (3.0 * r[2] ** 2 / r2 - 1.0) / (2.0 * rn ** 3)


def j2_acceleration(r, mu, j2, radius, pole=None):
    """Closed-form J2 acceleration [m/s^2] (corrected thesis §5.1.1 formula; see ERRATUM above).

    This is the physics model as printed (corrected), not a derivative of another model; the
    tests check it equals jax.grad(j2_potential). ``pole``: unit vector of the Earth's axis in
    the frame of r (default e_z, r Earth-fixed). J2 is axisymmetric, so with z = pole·r the
    printed formula reads a = k ((5 z²/r² − 1) r − 2 z pole) in any frame: in ICRS with the
    frozen pole no Earth rotation angle is needed (the model's t-dependence drops out).
    """
    pole = jnp.array([0.0, 0.0, 1.0]) if pole is None else pole
    r2 = jnp.dot(r, r)
    k = 1.5 * mu * j2 * radius ** 2 / (r2 * r2 * jnp.sqrt(r2))
    z = jnp.dot(pole, r)
    return k * ((5.0 * z * z / r2 - 1.0) * r - 2.0 * z * pole)


# --------------------------------------------------------------------------------------------
# Third bodies
# --------------------------------------------------------------------------------------------
def third_body_acceleration(r, r_body, mu_body):
    """mu_l ((r_l - r)/|r_l - r|^3 - r_l/|r_l|^3) [m/s^2]; r, r_body geocentric [m]."""
    d = r_body - r
    dn = jnp.sqrt(jnp.dot(d, d))
    rb = jnp.sqrt(jnp.dot(r_body, r_body))
    return mu_body * (d / dn ** 3 - r_body / rb ** 3)


# --------------------------------------------------------------------------------------------
# Model
# --------------------------------------------------------------------------------------------
@jax.tree_util.register_pytree_node_class
@dataclass(frozen=True, eq=False)
class PerturbationModel:
    """Everything :func:`perturbing_acceleration` needs; a JAX pytree.

    Leaves: ``rot`` (EarthRotation), ``eph`` (ChebyshevEphemeris or None), ``gm``, ``radius``,
    ``j2``, ``mu_bodies`` (array aligned with ``bodies``). Static: ``gravity`` in
    {"none", "j2", "sh"}, ``degree``, ``order``, ``bodies`` (tuple of names), ``cs`` (the EGM96
    C and S as nested tuples: compile-time constants). Everything that depends on the epoch is
    a leaf, so models for different departure dates (E6) share one compiled solver.
    ``epoch`` (property): t0 in s TDB past J2000, a 0-d array.
    """
    rot: EarthRotation
    eph: ChebyshevEphemeris | None
    gm: jax.Array
    radius: jax.Array
    j2: jax.Array
    mu_bodies: jax.Array
    gravity: str = "none"
    degree: int = 0
    order: int = 0
    bodies: tuple = ()
    cs: tuple = ((), ())

    @property
    def epoch(self):
        return self.rot.epoch

    def tree_flatten(self):
        return ((self.rot, self.eph, self.gm, self.radius, self.j2, self.mu_bodies),
                (self.gravity, self.degree, self.order, self.bodies, self.cs))

    @classmethod
    def tree_unflatten(cls, aux, leaves):
        return cls(*leaves, *aux)


def _parse_geopotential(value, key):
    if value is None or value is False or (isinstance(value, str) and value.lower() == "none"):
        return "none", 0, 0
    if isinstance(value, str):
        if value.lower() == "j2":
            return "j2", 2, 0
        raise ConfigError(key, value, "unknown geopotential model; expected 'j2', null or "
                          "{degree: n, order: m} with 2 <= n <= 4")
    if isinstance(value, dict):
        extra = set(value) - {"degree", "order"}
        if extra:
            k = sorted(extra)[0]
            raise ConfigError(f"{key}.{k}", value[k], "unknown key; expected degree, order")
        deg = value.get("degree")
        order = value.get("order", deg)
        if not isinstance(deg, int) or isinstance(deg, bool) or not 2 <= deg <= MAX_DEGREE:
            raise ConfigError(f"{key}.degree", deg, f"expected an integer 2..{MAX_DEGREE} (EGM96 file holds <= 4x4)")
        if not isinstance(order, int) or isinstance(order, bool) or not 0 <= order <= deg:
            raise ConfigError(f"{key}.order", order, f"expected an integer 0..degree ({deg})")
        return "sh", deg, order
    raise ConfigError(key, value, "unknown geopotential model; expected 'j2', null or {degree, order}")


def build_model(config, epoch_utc: str, ephemeris=None, key: str = "perturbations") -> PerturbationModel:
    """Build a :class:`PerturbationModel` from a config mapping (see module docstring).

    epoch_utc: initial epoch as UTC string ("2021-05-09T12:00:00"); fixes NPB(t0) and time offsets.
    ephemeris: ChebyshevEphemeris, or the path of an ephemeris window JSON artifact; needed only
    when third bodies are requested. Errors: ConfigError naming ``<key>.<field>`` and the value.
    """
    config = {} if config is None else config
    if not isinstance(config, dict):
        raise ConfigError(key, config, "expected a mapping")
    for k in config:
        if k not in MODEL_KEYS:
            raise ConfigError(f"{key}.{k}", config[k], f"unknown key; expected one of {list(MODEL_KEYS)}")
    gravity, degree, order = _parse_geopotential(config.get("geopotential"), f"{key}.geopotential")
    bodies = config.get("third_bodies") or []
    if isinstance(bodies, str) or not isinstance(bodies, (list, tuple)):
        raise ConfigError(f"{key}.third_bodies", bodies, "expected a list, e.g. [moon, sun]")
    for b in bodies:
        if b not in THIRD_BODY_MU:
            raise ConfigError(f"{key}.third_bodies", b, f"unknown body; expected one of {sorted(THIRD_BODY_MU)}")
    if len(set(bodies)) != len(bodies):
        raise ConfigError(f"{key}.third_bodies", list(bodies), "duplicate body")
    if not isinstance(epoch_utc, str):
        raise ConfigError(f"{key}.epoch", epoch_utc, "expected a UTC date string 'YYYY-MM-DDTHH:MM:SS'")
    rot = earth_rotation(epoch_utc, method=config.get("earth_angle", "era"),
                         ut1_minus_utc=config.get("ut1_minus_utc", 0.0), key=key)
    eph = None
    if bodies:
        if ephemeris is None:
            raise ConfigError(f"{key}.third_bodies", list(bodies), "needs an ephemeris window (none given)")
        eph = load_ephemeris(ephemeris) if isinstance(ephemeris, (str, Path)) else ephemeris
        eph.check_time(float(rot.epoch), key=f"{key}.epoch")
    egm = load_egm96()
    return PerturbationModel(
        rot, eph, jnp.float64(egm["gm"]),
        jnp.float64(egm["radius"]), jnp.float64(egm["j2"]),
        jnp.asarray([THIRD_BODY_MU[b] for b in bodies], dtype=jnp.float64).reshape(len(bodies)),
        gravity, degree, order, tuple(bodies),
        (tuple(map(tuple, egm["C"].tolist())), tuple(map(tuple, egm["S"].tolist()))))


def acceleration_terms(r, t, model: PerturbationModel, skip=()) -> dict:
    """Each perturbing acceleration [m/s^2, ICRS] by name: 'geopotential' | 'j2', and bodies;
    the terms named in ``skip`` are left out (not evaluated)."""
    r = jnp.asarray(r, dtype=jnp.float64)
    t = jnp.asarray(t, dtype=jnp.float64)
    out = {}
    if model.gravity == "j2" and "j2" not in skip:            # the frozen pole, NPB's third row
        out["j2"] = j2_acceleration(r, model.gm, model.j2, model.radius, pole=model.rot.npb[2])
    elif model.gravity not in ("none", "j2") and "geopotential" not in skip:
        theta = earth_angle(t, model.rot)
        r_f = to_itrs(r, theta, model.rot)                    # M(t) r, elementwise (frames.py)
        a_f = geopotential_acceleration(r_f, np.array(model.cs[0]), np.array(model.cs[1]),
                                        model.gm, model.radius, model.degree, model.order)
        out["geopotential"] = to_icrs(a_f, theta, model.rot)
    if set(model.bodies) - set(skip):
        pos = dict(zip(("moon", "sun"), model.eph.positions(t)))
        for i, b in enumerate(model.bodies):
            if b not in skip:
                out[b] = third_body_acceleration(r, pos[b], model.mu_bodies[i])
    return out


def _total(terms: dict):
    total = jnp.zeros(3, dtype=jnp.float64)
    for v in terms.values():
        total = total + v
    return total


def perturbing_acceleration(r, t, model: PerturbationModel):
    """Total perturbing acceleration [m/s^2] in ICRS axes at geocentric r [m, ICRS], t [s TDB
    past J2000]. Pure JAX: jit it with ``model`` as an argument or closed over."""
    return _total(acceleration_terms(r, t, model))


def _term_keys(model: PerturbationModel) -> dict:
    """Each term's name → what fixes its form (static): two models share a term where these agree."""
    keys = {}
    if model.gravity == "j2":
        keys["j2"] = ("j2", model.rot.method)
    elif model.gravity != "none":
        keys["geopotential"] = (model.gravity, model.degree, model.order, model.cs, model.rot.method)
    keys.update({b: (b,) for b in model.bodies})
    return keys


def shared_terms(frm: PerturbationModel, to: PerturbationModel) -> tuple:
    """The terms of the same form in both models (their data: :func:`check_blend`)."""
    a, b = _term_keys(frm), _term_keys(to)
    return tuple(k for k in a if b.get(k) == a[k])


def _term_data(model: PerturbationModel, name: str):
    if name in ("j2", "geopotential"):
        return (model.rot, model.gm, model.radius, model.j2)
    return (model.eph, model.mu_bodies[model.bodies.index(name)])


def check_blend(frm: PerturbationModel, to: PerturbationModel, key: str = "pert_from") -> None:
    """Raise ValueError unless every term of the same form in ``frm`` and ``to`` has the same
    data (epoch, Earth orientation, constants, ephemeris): :func:`blended_acceleration`
    evaluates such a term once. Concrete models only (not under jit)."""
    for name in shared_terms(frm, to):
        (la, ta), (lb, tb) = (jax.tree_util.tree_flatten(_term_data(m, name)) for m in (frm, to))
        if ta != tb or not all(np.array_equal(np.asarray(x), np.asarray(y)) for x, y in zip(la, lb)):
            raise ValueError(f"{key}: the {name} term differs in its data from the target model's "
                             "(epoch, orientation, constants or ephemeris); a model blend needs them equal")


def blended_acceleration(r, t, to: PerturbationModel, frm: PerturbationModel, tau):
    """The force-model blend a = τ a_to + (1 − τ) a_from [m/s^2, ICRS], each term once:

        a = Σ_shared a_k + τ Σ_(to only) a_k + (1 − τ) Σ_(from only) a_k,

    equal to the blend of the totals where the shared terms (same form, :func:`shared_terms`)
    have the same data, which :func:`check_blend` verifies where the blend is set up. E8's
    4×4 → 4×4 + Moon + Sun thus evaluates the 4×4 geopotential once, not twice."""
    shared = shared_terms(frm, to)
    a_to = acceleration_terms(r, t, to)
    common = {k: v for k, v in a_to.items() if k in shared}
    only_to = {k: v for k, v in a_to.items() if k not in shared}
    only_from = acceleration_terms(r, t, frm, skip=shared)
    return _total(common) + tau * _total(only_to) + (1.0 - tau) * _total(only_from)
