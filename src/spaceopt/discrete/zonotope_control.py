r"""Time-optimal discrete orbit correction: maximum principle versus dynamic programming (spec D4).

Model (linearised motion near a circular orbit, unit radius and rate), state z = (dr, dv_R, dv_T)::

    z' = A z + (0, w1, w2),   A = [[0, 1, 0], [1, 0, 2], [0, -1, 0]],
    exp(A t) = [[2 - cos t, sin t, 2 - 2 cos t], [sin t, cos t, 2 sin t], [cos t - 1, -sin t, 2 cos t - 1]].

Discretised with step dt: x(k+1) = At x(k) + Bt w(k), At = exp(A dt), w(k) in [-a, a]^2, with

* relay (zero-order hold) control: Bt = int_0^dt exp(A s) ds [e2 e3]
  = [[1 - cos dt, 2 dt - 2 sin dt], [sin dt, 2 - 2 cos dt], [cos dt - 1, 2 sin dt - dt]];
* impulsive control (a velocity kick at the start of every step): Bt = exp(A dt) [e2 e3]
  = [[sin dt, 2 - 2 cos dt], [cos dt, 2 sin dt], [-sin dt, 2 cos dt - 1]].

General form x(k+1) = A(k) x(k) + u(k), u(k) in U(k). The 0-controllable sets are the Minkowski
sums X(N, k) = sum_{i=0}^{N-1} -Phi(k, i) U(k + i), Phi(k, i) = A(k)^-1 ... A(k + i)^-1, and
N_min = min{N : x0 in X(N, 0)}.

* Dynamic programming (spec D4, appendix): original steps, U = Bt [-a, a]^2 (a parallelogram),
  so X(N, k) is a zonotope with 2N generators -At^-(i+1) Bt e_j a. Its vertices come from the
  convex hull (scipy.spatial.ConvexHull, Qhull) of the 2^(2N) sign combinations; each step solves
  the linear program (scipy.optimize.linprog, HiGHS)

      min r  s.t.  A(k) x + u = sum_i lambda_i x^i,  sum_i lambda_i <= r,  0 <= lambda_i <= r,
                   u = Bt w,  -a <= w <= a,

  i.e. u(k) = argmin gauge(A(k) x + u, X(N - k - 1, k + 1)).
* Maximum principle (needs a strictly convex U): the source regroups three original steps into
  two steps with 3-D controls, u~(2k) = (w1(3k), w2(3k), w1(3k+1)), u~(2k+1) = (w2(3k+1),
  w1(3k+2), w2(3k+2)), A(2k) = At^2, A(2k+1) = At, B(2k) = [At b1, At b2, b1],
  B(2k+1) = [At b2, b1, b2] (b1, b2 the columns of Bt). Derivation: x(3k+2) = At^2 x(3k)
  + At Bt w(3k) + b1 w1(3k+1) + b2 w2(3k+1); the even regrouped step stops before the
  b2 w2(3k+1) kick, which the odd step carries forward through At. An odd number N of regrouped
  steps ends at an original state when the last w2 is zero, so N regrouped steps correspond to
  ceil(3N/2) original steps.
  The strictly convex control set is the ball U(k) = B(k) {|u~| <= a} (the published controls all
  have the same Euclidean norm alpha*a in u~ coordinates; see the report). Its support function is
  h_U(c) = a |B^T c|, so X(N, 0) has support h(c) = a sum_i |(Phi_i B(i))^T c| and the gauge of x0 is
  1 / min{h(c) : c.x0 = 1}, a smooth convex problem in two variables (solved with the analytic
  gradient and Hessian: scipy's trust-ncg, then MINPACK hybr on grad = 0 to polish the normal).
  With alpha = gauge(x0, X(N_min, 0)) and psi(0) = -c*,
  psi(k+1) = A(k)^-T psi(k), the control is u(k) = alpha argmax_{u in U(k)} (A(k)^-T psi(k), u)
  = alpha a B(k) g / |g|, g = B(k)^T A(k)^-T psi(k); it reaches the origin in exactly N_min steps.

No hand-written LP or hull code: HiGHS and Qhull do that work.
"""
from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linprog, minimize, minimize_scalar, root
from scipy.spatial import ConvexHull

from ..errors import ConfigError, ConvergenceError

CONTROLS = ("relay", "impulsive")


# --------------------------------------------------------------------------------------------
# Model
# --------------------------------------------------------------------------------------------
def transition(t: float) -> np.ndarray:
    """exp(A t) of the linearised near-circular motion (closed form of the spec)."""
    c, s = np.cos(t), np.sin(t)
    return np.array([[2 - c, s, 2 - 2 * c], [s, c, 2 * s], [c - 1, -s, 2 * c - 1]], dtype=np.float64)


def input_matrix(dt: float, control: str) -> np.ndarray:
    """Bt (3x2) for relay (zero-order hold) or impulsive control."""
    c, s = np.cos(dt), np.sin(dt)
    if control == "relay":
        return np.array([[1 - c, 2 * dt - 2 * s], [s, 2 - 2 * c], [c - 1, 2 * s - dt]], dtype=np.float64)
    if control == "impulsive":
        return np.array([[s, 2 - 2 * c], [c, 2 * s], [-s, 2 * c - 1]], dtype=np.float64)
    raise ConfigError("orbit_correction.controls", control, f"must be one of {CONTROLS}")


def regrouped_system(dt: float, control: str):
    """[(A_even, B_even), (A_odd, B_odd)] of the source's 3-step -> 2-step regrouping."""
    At = transition(dt)
    Bt = input_matrix(dt, control)
    b1, b2 = Bt[:, 0], Bt[:, 1]
    return [(At @ At, np.column_stack([At @ b1, At @ b2, b1])),
            (At, np.column_stack([At @ b2, b1, b2]))]


def regrouped_to_original_steps(n: int) -> int:
    return int(np.ceil(1.5 * n))


# --------------------------------------------------------------------------------------------
# Zonotopes (dynamic programming)
# --------------------------------------------------------------------------------------------
def zonotope_generators(dt: float, control: str, n: int, a_max: float) -> np.ndarray:
    """Generators (3 x 2n) of X(n, k) = sum_{i<n} -At^-(i+1) Bt [-a, a]^2 (time invariant)."""
    At_inv = np.linalg.inv(transition(dt))
    Bt = input_matrix(dt, control)
    gens, P = [], np.eye(3)
    for _ in range(n):
        P = P @ At_inv
        gens.append(-P @ Bt * a_max)
    return np.hstack(gens) if gens else np.zeros((3, 0))


def zonotope_vertices(generators: np.ndarray) -> np.ndarray:
    """Vertices (M x 3) of the zonotope {G beta : |beta|_inf <= 1}, via Qhull of the sign sums."""
    m = generators.shape[1]
    if m == 0:
        return np.zeros((1, 3))
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=m)))
    pts = signs @ generators.T
    if m < 3:   # degenerate (planar or segment): all sign sums are the candidate vertices
        return np.unique(pts, axis=0)
    hull = ConvexHull(pts)
    return pts[np.sort(hull.vertices)]


def zonotope_hull(generators: np.ndarray) -> ConvexHull:
    m = generators.shape[1]
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=m)))
    return ConvexHull(signs @ generators.T)


def gauge_generators(x: np.ndarray, generators: np.ndarray) -> float:
    """Gauge of x w.r.t. the zonotope G [-1, 1]^m: min ||beta||_inf s.t. G beta = x (HiGHS LP).

    An independent membership check (generator form) beside the vertex form of the DP."""
    m = generators.shape[1]
    if m == 0:
        return 0.0 if np.allclose(x, 0) else np.inf
    # variables (beta, r): min r, G beta = x, -r <= beta_j <= r
    c = np.r_[np.zeros(m), 1.0]
    A_ub = np.block([[np.eye(m), -np.ones((m, 1))], [-np.eye(m), -np.ones((m, 1))]])
    res = linprog(c, A_ub=A_ub, b_ub=np.zeros(2 * m), A_eq=np.c_[generators, np.zeros(3)], b_eq=x,
                  bounds=[(None, None)] * m + [(0, None)], method="highs")
    return float(res.fun) if res.status == 0 else np.inf


def dp_step_lp(Ax: np.ndarray, Bt: np.ndarray, a_max: float, vertices: np.ndarray):
    """The appendix LP: min r s.t. Ax + Bt w = sum lambda_i x^i, sum lambda <= r, 0 <= lambda <= r,
    |w| <= a. Returns (r, w, lambda, scipy result)."""
    M = vertices.shape[0]
    nw = Bt.shape[1]
    # variables: w (nw), lambda (M), r
    c = np.r_[np.zeros(nw + M), 1.0]
    A_eq = np.c_[Bt, -vertices.T, np.zeros(3)]
    b_eq = -Ax
    A_ub = np.vstack([np.r_[np.zeros(nw), np.ones(M), -1.0],
                      np.c_[np.zeros((M, nw)), np.eye(M), -np.ones((M, 1))]])
    b_ub = np.zeros(M + 1)
    bounds = [(-a_max, a_max)] * nw + [(0, None)] * M + [(0, None)]
    res = linprog(c, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq, bounds=bounds, method="highs")
    if res.status != 0:
        return np.inf, None, None, res
    return float(res.x[-1]), res.x[:nw], res.x[nw:nw + M], res


@dataclass
class Solution:
    method: str
    control: str
    n_min: int                      # in the method's own steps
    n_min_original: int             # in original steps
    x: np.ndarray                   # (n+1, 3) states
    u: np.ndarray                   # (n, 3) state-space increments, x(k+1) = A(k) x(k) + u(k)
    w: np.ndarray                   # (n, 2 or 3) control coordinates
    gauges: list                    # gauge of x0 w.r.t. X(N, 0) for N = 1..n_min
    alpha: float | None = None
    wall_time_s: float = 0.0
    extra: dict = field(default_factory=dict)


def smallest_horizon(gauge_at, n_max: int, tol: float, steps: str) -> tuple[int, list]:
    """N_min: the first N = 1..n_max whose 0-controllable set X(N, 0) holds x0 (gauge <= 1 + tol).

    ``gauge_at(N)`` is the gauge of x0 with respect to X(N, 0); returns (N_min, gauges up to N_min).
    """
    gauges = []
    for n in range(1, n_max + 1):
        gauges.append(gauge_at(n))
        if gauges[-1] <= 1 + tol:
            return n, gauges
    raise ConvergenceError(f"orbit_correction.n_max={n_max}: x0 not 0-controllable within "
                           f"{n_max} {steps}", {"gauges": gauges})


def solve_dp(x0, dt: float, control: str, a_max: float, n_max: int, tol: float = 1e-9) -> Solution:
    """Dynamic programming (original steps, box controls, vertex LP of the appendix)."""
    t0 = time.perf_counter()
    x0 = np.asarray(x0, dtype=np.float64)
    At, Bt = transition(dt), input_matrix(dt, control)
    verts = {0: np.zeros((1, 3))}

    def gauge_at(n):                                  # x0 in X(n, 0) iff gauge <= 1
        verts[n] = zonotope_vertices(zonotope_generators(dt, control, n, a_max))
        return _gauge_vertices(x0, verts[n])

    n_min, gauges = smallest_horizon(gauge_at, n_max, tol, f"steps ({control}, DP)")
    xs, us, ws, rs = [x0], [], [], []
    x = x0
    for k in range(n_min):
        r, w, lam, res = dp_step_lp(At @ x, Bt, a_max, verts[n_min - k - 1])
        if w is None:
            raise ConvergenceError(f"orbit_correction: DP step {k} LP failed ({res.message})", {})
        u = Bt @ w
        x = At @ x + u
        xs.append(x), us.append(u), ws.append(w), rs.append(r)
    sol = Solution("dynamic_programming", control, n_min, n_min, np.array(xs), np.array(us),
                   np.array(ws), gauges, wall_time_s=time.perf_counter() - t0,
                   extra={"step_gauges": rs, "n_vertices": {n: len(v) for n, v in verts.items()}})
    return sol


def _gauge_vertices(x, vertices):
    """min r s.t. x = sum lambda_i v_i, sum lambda <= r, lambda >= 0 (HiGHS)."""
    M = vertices.shape[0]
    c = np.r_[np.zeros(M), 1.0]
    A_eq = np.c_[vertices.T, np.zeros(3)]
    A_ub = np.r_[np.ones(M), -1.0][None, :]
    res = linprog(c, A_ub=A_ub, b_ub=[0.0], A_eq=A_eq, b_eq=x, bounds=[(0, None)] * (M + 1),
                  method="highs")
    return float(res.fun) if res.status == 0 else np.inf


# --------------------------------------------------------------------------------------------
# Maximum principle (regrouped, ball control sets)
# --------------------------------------------------------------------------------------------
def _mp_matrices(dt, control, n):
    """M_i = Phi_i B(i) (Phi_i = A(0)^-1...A(i)^-1), A(i), B(i) for i < n."""
    sysm = regrouped_system(dt, control)
    Ms, As, Bs, P = [], [], [], np.eye(3)
    for i in range(n):
        A_i, B_i = sysm[i % 2]
        P = P @ np.linalg.inv(A_i)
        Ms.append(P @ B_i)
        As.append(A_i), Bs.append(B_i)
    return Ms, As, Bs


def ball_sum_gauge(x0, Ms, a_max, c_start=None):
    """Gauge of x0 w.r.t. sum_i -M_i Ball(a): 1 / min{a sum |M_i^T c| : c.x0 = 1}; returns (gauge, c*)."""
    x0 = np.asarray(x0, dtype=np.float64)
    c0 = x0 / (x0 @ x0)
    Z = np.linalg.svd(x0[None, :])[2][1:].T        # orthonormal basis of x0-perp (3 x 2)

    def h(z):
        c = c0 + Z @ z
        val = sum(np.linalg.norm(M.T @ c) for M in Ms)
        return a_max * val

    def grad(z):
        c = c0 + Z @ z
        g = np.zeros(3)
        for M in Ms:
            v = M.T @ c
            nv = np.linalg.norm(v)
            if nv > 0:
                g += M @ v / nv
        return a_max * (Z.T @ g)

    def hess(z):
        c = c0 + Z @ z
        H = np.zeros((3, 3))
        for M in Ms:
            v = M.T @ c
            nv = np.linalg.norm(v)
            if nv > 0:
                H += M @ (np.eye(len(v)) / nv - np.outer(v, v) / nv ** 3) @ M.T
        return a_max * (Z.T @ H @ Z)

    z0 = np.zeros(2) if c_start is None else Z.T @ (c_start / (c_start @ x0) - c0)
    res = minimize(h, z0, jac=grad, hess=hess, method="trust-ncg", options={"gtol": 1e-13 * a_max})
    # polish: the first-order condition grad = 0 is better conditioned than comparisons of h near the
    # minimum (which stall at ~sqrt(eps)); MINPACK's hybrid method with the analytic Hessian
    pol = root(grad, res.x, jac=hess, method="hybr", options={"xtol": 1e-15})
    better = np.linalg.norm(grad(pol.x)) < np.linalg.norm(grad(res.x)) and h(pol.x) <= res.fun * (1 + 1e-12)
    z = pol.x if better else res.x
    c = c0 + Z @ z
    return float(1.0 / h(z)), c


def solve_mp(x0, dt: float, control: str, a_max: float, n_max: int, tol: float = 1e-9) -> Solution:
    """Maximum principle on the regrouped system with ball control sets (see module docstring)."""
    t0 = time.perf_counter()
    x0 = np.asarray(x0, dtype=np.float64)
    last = {"c": None}                                # normal of the last gauge: warm start, then psi(0)

    def gauge_at(n):
        last["Ms"], last["As"], last["Bs"] = _mp_matrices(dt, control, n)
        g, last["c"] = ball_sum_gauge(x0, last["Ms"], a_max, c_start=last["c"])
        return g

    n_min, gauges = smallest_horizon(gauge_at, n_max, tol, f"regrouped steps ({control}, MP)")
    As, Bs, c = last["As"], last["Bs"], last["c"]
    alpha = gauges[-1]
    psi = -c                                          # -psi(0) in the normal cone at x0/alpha
    xs, us, ws, x = [x0], [], [], x0
    for k in range(n_min):
        A_inv_T = np.linalg.inv(As[k]).T
        g = Bs[k].T @ (A_inv_T @ psi)
        w = alpha * a_max * g / np.linalg.norm(g)
        u = Bs[k] @ w
        x = As[k] @ x + u
        psi = A_inv_T @ psi
        xs.append(x), us.append(u), ws.append(w)
    return Solution("maximum_principle", control, n_min, regrouped_to_original_steps(n_min),
                    np.array(xs), np.array(us), np.array(ws), gauges, alpha=alpha,
                    wall_time_s=time.perf_counter() - t0,
                    extra={"normal": c, "w_norm_over_a": [float(np.linalg.norm(w) / a_max) for w in ws]})


def mp_membership_gauges(sol: Solution, dt: float, a_max: float) -> list[float]:
    """gauge(x(k), X~(N_min - k, k)) along an MP trajectory (regrouped, ball sets); <= alpha."""
    out = []
    sysm = regrouped_system(dt, sol.control)
    for k in range(sol.n_min):
        # X(N - k, k): the regrouping parity is that of k
        Ms, P = [], np.eye(3)
        for i in range(k, sol.n_min):
            A_i, B_i = sysm[i % 2]
            P = P @ np.linalg.inv(A_i)
            Ms.append(P @ B_i)
        out.append(ball_sum_gauge(sol.x[k], Ms, a_max)[0] if np.linalg.norm(sol.x[k]) > 0 else 0.0)
    return out


def dp_membership_gauges(sol: Solution, dt: float, a_max: float) -> list[float]:
    """gauge(x(k), X(N_min - k)) along a DP trajectory, by the generator LP (independent of the
    vertex LP used to build it); every entry must be <= 1."""
    out = []
    for k in range(sol.n_min + 1):
        G = zonotope_generators(dt, sol.control, sol.n_min - k, a_max)
        out.append(gauge_generators(sol.x[k], G))
    return out


# --------------------------------------------------------------------------------------------
# Inferring dt from published maximum-principle tables
# --------------------------------------------------------------------------------------------
def one_step_residual(dt: float, x_tab: np.ndarray, u_tab: np.ndarray) -> np.ndarray:
    """Residuals x(k+1) - A(k; dt) x(k) - u(k) of a regrouped table (A(even) = At^2, A(odd) = At)."""
    At = transition(dt)
    res = []
    for k in range(len(u_tab)):
        A_k = At @ At if k % 2 == 0 else At
        res.append(x_tab[k + 1] - A_k @ x_tab[k] - u_tab[k])
    return np.array(res)


def published_mp_tables(lookup: dict, controls) -> dict:
    """{control: (x (n+1, 3), u (n, 3))} from a ``published_lookup`` of the published file (cases
    ``d4_mp_<control>``, quantities ``x<i>[<k>]`` and ``u<i>[<k>]``)."""
    out = {}
    for c in controls:
        ks = sorted({int(q.split("[")[1].rstrip("]")) for (case, q) in lookup
                     if case == f"d4_mp_{c}" and q.startswith("x")})
        if not ks:
            continue
        x = np.array([[lookup[(f"d4_mp_{c}", f"x{i + 1}[{k}]")]["value"] for i in range(3)] for k in ks],
                     dtype=np.float64)
        u = np.array([[lookup[(f"d4_mp_{c}", f"u{i + 1}[{k}]")]["value"] for i in range(3)] for k in ks[:-1]],
                     dtype=np.float64)
        out[c] = (x, u)
    return out


def infer_dt(tables: list[tuple[np.ndarray, np.ndarray]], grid: tuple[float, float, int],
             xatol: float = 1e-10) -> dict:
    """Least-squares dt: minimise the summed squared one-step residuals of all tables over dt.

    A grid scan locates the basin (the residual is periodic in dt), a bounded Brent search refines
    it. Returns the estimate, the RMS residual at it and the scan (for the fit figure)."""
    lo, hi, n = grid
    if not (0 < lo < hi) or n < 3:
        raise ConfigError("orbit_correction.dt_inference.grid", list(grid), "need 0 < lo < hi and n >= 3")
    n_entries = sum(u.size for _, u in tables)

    def sse(dt):
        return float(sum(np.sum(one_step_residual(dt, x, u) ** 2) for x, u in tables))

    ts = np.linspace(lo, hi, int(n))
    vals = np.array([sse(t) for t in ts])
    i = int(np.argmin(vals))
    a, b = ts[max(i - 1, 0)], ts[min(i + 1, len(ts) - 1)]
    res = minimize_scalar(sse, bounds=(a, b), method="bounded", options={"xatol": xatol})
    per_table = [float(np.sqrt(np.mean(one_step_residual(res.x, x, u) ** 2))) for x, u in tables]
    return {"dt": float(res.x), "rms": float(np.sqrt(res.fun / n_entries)), "rms_per_table": per_table,
            "scan_dt": ts, "scan_rms": np.sqrt(vals / n_entries)}


# --------------------------------------------------------------------------------------------
# The study (config -> results) and its figures (saved by the workflow script)
# --------------------------------------------------------------------------------------------
def time_method(fn, repeats: int) -> dict:
    """Median, min and max wall time (perf_counter) and median CPU time (process_time) of ``fn()``."""
    ts, cpu = [], []
    for _ in range(int(repeats)):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        ts.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return {"median_s": float(np.median(ts)), "min_s": float(np.min(ts)), "max_s": float(np.max(ts)),
            "median_cpu_s": float(np.median(cpu)), "repeats": int(repeats)}


def check_config(cfg: dict) -> None:
    x0 = cfg.get("x0")
    if not (isinstance(x0, (list, tuple)) and len(x0) == 3):
        raise ConfigError("orbit_correction.x0", x0, "must be a list of three numbers")
    for c in cfg.get("controls", []):
        if c not in CONTROLS:
            raise ConfigError("orbit_correction.controls", c, f"must be one of {CONTROLS}")
        a = cfg.get("a_max", {}).get(c)
        if not (isinstance(a, (int, float)) and a > 0):
            raise ConfigError(f"orbit_correction.a_max.{c}", a, "must be a positive number")
    dt = cfg.get("dt")
    if not (dt == "infer" or (isinstance(dt, (int, float)) and dt > 0)):
        raise ConfigError("orbit_correction.dt", dt, "must be a positive number or 'infer'")
    n_max = cfg.get("n_max")
    if not (isinstance(n_max, int) and 1 <= n_max <= 12):
        raise ConfigError("orbit_correction.n_max", n_max, "must be an integer in [1, 12]")


def resolve_dt(cfg: dict, published_tables: dict | None) -> tuple[float, dict | None]:
    """dt from the config, or inferred from the published MP tables and rounded (see infer_dt)."""
    if cfg["dt"] != "infer":
        return float(cfg["dt"]), None
    if not published_tables:
        raise ConfigError("orbit_correction.dt", "infer", "needs the published MP tables")
    di = cfg["dt_inference"]
    fit = infer_dt(list(published_tables.values()), tuple(di["grid"]))
    fit["per_control"] = {c: infer_dt([tab], tuple(di["grid"]))["dt"] for c, tab in published_tables.items()}
    step = di["round_to"]
    dt = round(fit["dt"] / step) * step if step > 0 else fit["dt"]
    fit["dt_rounded"] = dt
    fit["tables"] = published_tables
    fit["rms_at_rounded"] = float(np.sqrt(np.mean(np.concatenate(
        [one_step_residual(dt, x, u).ravel() for x, u in published_tables.values()]) ** 2)))
    return dt, fit


def run_study(cfg: dict, published_tables: dict | None = None, timing: bool = True) -> dict:
    """All D4 numbers from the ``orbit_correction`` config section (no I/O).

    ``published_tables`` maps a control to its published MP (x, u) table; it is used only to infer
    dt (when cfg['dt'] == 'infer') and never as a starting guess."""
    check_config(cfg)
    dt, fit = resolve_dt(cfg, published_tables)
    x0 = np.asarray(cfg["x0"], dtype=np.float64)
    out = {"dt": dt, "dt_fit": fit, "solutions": {}, "membership": {}, "timing": {}, "zonotopes": {}}
    for c in cfg["controls"]:
        a = cfg["a_max"][c]
        mp = solve_mp(x0, dt, c, a, cfg["n_max"], cfg["gauge_tol"])
        dp = solve_dp(x0, dt, c, a, cfg["n_max"], cfg["gauge_tol"])
        out["solutions"][("maximum_principle", c)] = mp
        out["solutions"][("dynamic_programming", c)] = dp
        out["membership"][("maximum_principle", c)] = mp_membership_gauges(mp, dt, a)
        out["membership"][("dynamic_programming", c)] = dp_membership_gauges(dp, dt, a)
        if timing:
            out["timing"][("maximum_principle", c)] = time_method(
                lambda: solve_mp(x0, dt, c, a, cfg["n_max"], cfg["gauge_tol"]), cfg["timing_repeats"])
            out["timing"][("dynamic_programming", c)] = time_method(
                lambda: solve_dp(x0, dt, c, a, cfg["n_max"], cfg["gauge_tol"]), cfg["timing_repeats"])
        for n in cfg["zonotope_plot_N"]:
            G = zonotope_generators(dt, c, n, a)
            out["zonotopes"][(c, n)] = {"generators": G, "vertices": zonotope_vertices(G),
                                        "gauge_x0": gauge_generators(x0, G)}
    return out


def table_rows(study: dict) -> list[dict]:
    """Rows of orbit_correction.csv: method, control, k, x1..x3, u1..u3 (u empty at the last k)."""
    rows = []
    for (method, c), s in study["solutions"].items():
        for k in range(s.x.shape[0]):
            row = {"method": method, "control": c, "k": k,
                   **{f"x{i + 1}": float(s.x[k, i]) for i in range(3)}}
            row.update({f"u{i + 1}": (float(s.u[k, i]) if k < s.u.shape[0] else "") for i in range(3)})
            rows.append(row)
    return rows


def reproduced_numbers(study: dict) -> dict:
    ours = {}
    for (method, c), s in study["solutions"].items():
        if method == "maximum_principle":
            for k in range(s.x.shape[0]):
                for i in range(3):
                    ours[(f"d4_mp_{c}", f"x{i + 1}[{k}]")] = float(s.x[k, i])
                    if k < s.u.shape[0]:
                        ours[(f"d4_mp_{c}", f"u{i + 1}[{k}]")] = float(s.u[k, i])
        ours[(f"d4_nmin_{c}", method)] = s.n_min_original
        t = study["timing"].get((method, c))
        if t:
            ours[(f"d4_time_{c}", f"{method}_s")] = t["median_s"]
    ours[("d4_dt", "dt_hint")] = study["dt"]
    return ours


def figures(study: dict, cfg: dict) -> dict:
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    figs = {}
    x0 = np.asarray(cfg["x0"])
    for c in cfg["controls"]:
        ns = cfg["zonotope_plot_N"]
        fig = plt.figure(figsize=(4 * len(ns), 4.2))
        for j, n in enumerate(ns):
            ax = fig.add_subplot(1, len(ns), j + 1, projection="3d")
            V = study["zonotopes"][(c, n)]["vertices"]
            if V.shape[0] >= 4:
                hull = ConvexHull(V)
                ax.add_collection3d(Poly3DCollection(V[hull.simplices], alpha=0.25, facecolor="tab:blue",
                                                     edgecolor="k", linewidths=0.15))
            ax.scatter(*x0, color="r", s=12, label="x0")
            lim = np.abs(np.vstack([V, x0])).max(axis=0) * 1.05
            ax.set_xlim(-lim[0], lim[0])
            ax.set_ylim(-lim[1], lim[1])
            ax.set_zlim(-lim[2], lim[2])
            g = study["zonotopes"][(c, n)]["gauge_x0"]
            ax.set_title(f"X({n}, 0), {c}: {V.shape[0]} vertices\ngauge(x0) = {g:.4f}"
                         f" ({'inside' if g <= 1 else 'outside'})", fontsize=8)
            ax.set_xlabel("dr", fontsize=7)
            ax.set_ylabel("dv_R", fontsize=7)
            ax.set_zlabel("dv_T", fontsize=7)
            ax.tick_params(labelsize=5)
        figs[f"zonotopes_{c}"] = fig

    fit = study["dt_fit"]
    if fit is not None:
        fig, axes = plt.subplots(1, 2, figsize=(11, 4))
        axes[0].semilogy(fit["scan_dt"], fit["scan_rms"], lw=0.8)
        axes[0].axvline(fit["dt"], color="r", ls="--", lw=0.8, label=f"least squares dt = {fit['dt']:.6f}")
        axes[0].set_xlabel("candidate dt")
        axes[0].set_ylabel("RMS of x(k+1) - A(k; dt) x(k) - u(k)")
        axes[0].set_title("dt fit on the published MP tables (A(even) = At², A(odd) = At)", fontsize=8)
        axes[0].legend(fontsize=7)
        for c, mk in zip(cfg["controls"], ("o", "s")):
            s = study["solutions"].get(("maximum_principle", c))
            pub = (fit.get("tables") or {}).get(c)
            if s is None or pub is None:
                continue
            for i in range(3):
                axes[1].plot(range(s.x.shape[0]), s.x[:, i], lw=0.7, color=f"C{i}")
                axes[1].plot(range(pub[0].shape[0]), pub[0][:, i], mk, mfc="none", color=f"C{i}", ms=5,
                             label=f"published x{i + 1} ({c})")
        axes[1].set_xlabel("regrouped step k")
        axes[1].set_title(f"MP trajectories at dt = {study['dt']:g} (lines) vs published (markers); "
                          f"RMS one-step residual {fit['rms_at_rounded']:.1e}", fontsize=8)
        axes[1].legend(fontsize=6, ncol=2)
        fig.tight_layout()
        figs["dt_fit"] = fig

    fig, axes = plt.subplots(1, len(cfg["controls"]), figsize=(5.5 * len(cfg["controls"]), 4), squeeze=False)
    for ax, c in zip(axes[0], cfg["controls"]):
        dp = study["solutions"][("dynamic_programming", c)]
        mp = study["solutions"][("maximum_principle", c)]
        t_mp = np.r_[0, np.cumsum([2 if k % 2 == 0 else 1 for k in range(mp.n_min)])]
        for i, name in enumerate(("dr", "dv_R", "dv_T")):
            ax.plot(range(dp.x.shape[0]), dp.x[:, i], "-o", ms=3, color=f"C{i}", label=f"{name} DP")
            ax.plot(t_mp, mp.x[:, i], ":s", ms=3, color=f"C{i}", mfc="none", label=f"{name} MP")
        ax.axhline(0, color="k", lw=0.4)
        ax.set_xlabel("original step (dt)")
        ax.set_title(f"{c}: DP N_min = {dp.n_min_original}, MP N_min = {mp.n_min_original}", fontsize=9)
        ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    figs["trajectories"] = fig
    return figs


def reproduction_notes(study: dict) -> dict:
    notes = {}
    fit = study["dt_fit"]
    if fit is not None:
        notes[("d4_dt", "dt_hint")] = (
            f"least-squares dt = {fit['dt']:.7f} (RMS {fit['rms']:.1e}); the even regrouped step spans 2 dt")
    for c in CONTROLS:
        notes[(f"d4_nmin_{c}", "maximum_principle")] = ("regrouped N_min n corresponds to ceil(3n/2) original steps; "
                                                         "ball control sets |u~| <= a_max")
        for m in ("maximum_principle", "dynamic_programming"):
            notes[(f"d4_time_{c}", f"{m}_s")] = "ours: median wall time of N_min search + trajectory (Python, HiGHS)"
    return notes
