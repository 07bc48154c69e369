"""D3: angular-momentum stabilisation of a microsatellite from the Bellman equation (spec 05-discrete.md §D3).

Model (principal axes, w = (wx, wy, wz), |u_i| <= b_i)::

    wx' = (Iy - Iz)/(Iy*Iz) * wy*wz + ux
    wy' = (Iz - Ix)/(Iz*Ix) * wz*wx + uy
    wz' = (Ix - Iy)/(Ix*Iy) * wx*wy + uz

Bellman (HJB) equation for V(t, w), the probability of keeping w inside the box Q on [t, T]::

    dV/dt + f(w) . grad V + sum_i b_i |dV/dw_i| = 0,      V(T, w) = 1_Q(w),  V = 0 on the boundary,

with the feedback u_i = b_i sign(dV/dw_i).

Discretisation: the Kushner-Dupuis Markov-chain approximation. On the grid w = h*k (k integer) and
time step dt, for every component i and control u_i in {-b_i, +b_i} the drift d_i = f_i(w) + u_i
moves the chain one node up (probability d_i^+ dt/h) or down (d_i^- dt/h); the chain stays with
the remaining probability. The dynamic-programming step, backwards in time, is

    V(t - dt, w) = V(t, w) + dt/h * sum_i max_{u_i = +-b_i} [ d_i^+ (V(w + h e_i) - V(w))
                                                           + d_i^- (V(w - h e_i) - V(w)) ],

(the maximum separates by component because each u_i moves only its own coordinate). This is the
upwind scheme for the HJB equation; it is monotone, and V stays a probability (0 <= V <= 1), as long
as the CFL number dt/h * max_w sum_i |d_i| <= 1, which is checked. No library does this 3-D
explicit upwind sweep; it is a few vectorised numpy lines.

Choices for the ambiguities (spec D3):
- units of Q: rad/s. The grid step is 0.01 rad/s; in deg/s Q = [-0.1, 0.1] deg/s would be
  0.0035 rad/s wide, less than one grid cell, and the published points (wy = wz = +-0.1) would lie
  at 5.7 deg/s, far outside Q.
- boundary conditions: the computational domain is the box [-L, L]^3 (L = domain_half_width,
  default Q's half-width plus one grid step); its boundary nodes hold V = 0 at all times. With
  ``exit: absorbing`` (default) every node outside Q is a boundary node (the chain that leaves Q
  is lost: V is the probability of staying in Q); with ``exit: terminal_only`` nodes between Q and
  the domain boundary evolve too and V is the probability of being in Q at T.
- Q is closed: nodes on its faces belong to Q (the published points are corners of Q).

Symmetry (used as a test and an erratum): S(wx, wy, wz) = (wx, -wy, -wz) satisfies f(Sw) = S f(w)
and maps Q and the control box onto themselves, so V(t, Sw) = V(t, w) for the exact equation and
for the scheme; the two published points are images of each other under S.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import RegularGridInterpolator

from ..errors import ConfigError

DEG = math.pi / 180.0


@dataclass(frozen=True)
class BellmanParams:
    inertia: tuple          # (Ix, Iy, Iz), kg m^2
    b: tuple                # control bounds, rad/s^2
    q: float                # half-width of Q, rad/s
    h: float                # grid step, rad/s
    dt: float               # time step, s
    horizon: float          # T, s
    domain_half_width: float
    absorbing: bool

    @property
    def coeffs(self):
        ix, iy, iz = self.inertia
        return ((iy - iz) / (iy * iz), (iz - ix) / (iz * ix), (ix - iy) / (ix * iy))

    @property
    def n_q(self) -> int:
        return int(round(self.q / self.h))

    @property
    def n_dom(self) -> int:
        return int(round(self.domain_half_width / self.h))

    @property
    def n_steps(self) -> int:
        return int(round(self.horizon / self.dt))


def _num(cfg, key, prefix, positive=True):
    if key not in cfg:
        raise ConfigError(f"{prefix}.{key}", None, "missing")
    v = cfg[key]
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise ConfigError(f"{prefix}.{key}", v, "not a number") from None
    if not math.isfinite(x) or (positive and x <= 0):
        raise ConfigError(f"{prefix}.{key}", v, "must be a finite number > 0")
    return x


def _triple(cfg, key, prefix):
    v = cfg.get(key)
    if not isinstance(v, (list, tuple)) or len(v) != 3:
        raise ConfigError(f"{prefix}.{key}", v, "must be a list of 3 numbers")
    out = []
    for x in v:
        try:
            x = float(x)
        except (TypeError, ValueError):
            raise ConfigError(f"{prefix}.{key}", v, "must be a list of 3 numbers") from None
        if not math.isfinite(x) or x <= 0:
            raise ConfigError(f"{prefix}.{key}", v, "entries must be finite and > 0")
        out.append(x)
    return tuple(out)


def params_from_config(cfg: dict, horizon_s: float | None = None, prefix="bellman") -> BellmanParams:
    units = cfg.get("q_units", "rad/s")
    if units not in ("rad/s", "deg/s"):
        raise ConfigError(f"{prefix}.q_units", units, "must be 'rad/s' or 'deg/s'")
    scale = 1.0 if units == "rad/s" else DEG
    q = _num(cfg, "q_half_width", prefix) * scale
    h = _num(cfg, "grid_step", prefix)
    dt = _num(cfg, "dt_s", prefix)
    T = _num(cfg, "horizon_s", prefix) if horizon_s is None else float(horizon_s)
    L = float(cfg.get("domain_half_width") or (q + h))
    if abs(q / h - round(q / h)) > 1e-9 or round(q / h) < 1:
        raise ConfigError(f"{prefix}.q_half_width", cfg["q_half_width"],
                          f"must be a positive multiple of grid_step={h:g} rad/s (in rad/s)")
    if abs(L / h - round(L / h)) > 1e-9 or L < q + h - 1e-12:
        raise ConfigError(f"{prefix}.domain_half_width", cfg.get("domain_half_width"),
                          "must be a multiple of grid_step and at least q_half_width + grid_step")
    if abs(T / dt - round(T / dt)) > 1e-9:
        raise ConfigError(f"{prefix}.horizon_s", T, f"must be a multiple of dt_s={dt:g}")
    exit_ = cfg.get("exit", "absorbing")
    if exit_ not in ("absorbing", "terminal_only"):
        raise ConfigError(f"{prefix}.exit", exit_, "must be 'absorbing' or 'terminal_only'")
    p = BellmanParams(inertia=_triple(cfg, "inertia_kg_m2", prefix), b=_triple(cfg, "b", prefix),
                      q=q, h=h, dt=dt, horizon=T, domain_half_width=L, absorbing=exit_ == "absorbing")
    cfl = cfl_number(p)
    if cfl > 1.0:
        raise ConfigError(f"{prefix}.dt_s", dt, f"CFL number {cfl:.3g} > 1: the scheme is not monotone")
    return p


def axis(p: BellmanParams) -> np.ndarray:
    """Grid coordinates of one component (integer multiples of h, symmetric about 0)."""
    return p.h * np.arange(-p.n_dom, p.n_dom + 1)


def drift(p: BellmanParams, W):
    """f(w) on arrays W = (wx, wy, wz)."""
    c = p.coeffs
    wx, wy, wz = W
    return (c[0] * wy * wz, c[1] * wz * wx, c[2] * wx * wy)


def cfl_number(p: BellmanParams) -> float:
    g = axis(p)
    W = np.meshgrid(g, g, g, indexing="ij")
    f = drift(p, W)
    return float(np.max(sum(np.abs(fi) + bi for fi, bi in zip(f, p.b))) * p.dt / p.h)


def masks(p: BellmanParams):
    k = np.arange(-p.n_dom, p.n_dom + 1)
    K = np.meshgrid(k, k, k, indexing="ij")
    in_q = np.all([np.abs(Ki) <= p.n_q for Ki in K], axis=0)
    on_edge = np.any([np.abs(Ki) == p.n_dom for Ki in K], axis=0)
    boundary = on_edge | (~in_q if p.absorbing else False)
    return in_q, boundary


def _shift(V, axis_, step):
    """V at the neighbour w + step*h*e_axis (edge nodes are boundary nodes and never read)."""
    return np.roll(V, -step, axis=axis_)


def solve(p: BellmanParams, store_every: int = 1) -> dict:
    """Backward dynamic programming of the Markov chain. Returns times t_k = k*dt (k = 0..N),
    V on the grid at every ``store_every``-th time (float64 array (n_t, n, n, n)), and the
    optimal control signs at t = 0."""
    g = axis(p)
    W = np.meshgrid(g, g, g, indexing="ij")
    f = drift(p, W)
    in_q, boundary = masks(p)
    lam = p.dt / p.h
    V = in_q.astype(np.float64)
    V[boundary] = 0.0
    N = p.n_steps
    stored = {N: V.copy()}
    usign = np.zeros((3,) + V.shape, dtype=np.int8)
    for n in range(N - 1, -1, -1):
        acc = np.zeros_like(V)
        for i in range(3):
            up, dn = _shift(V, i, +1) - V, _shift(V, i, -1) - V
            best = None
            for s in (-1, 1):
                d = f[i] + s * p.b[i]
                val = np.maximum(d, 0.0) * up + np.maximum(-d, 0.0) * dn
                if best is None:
                    best, arg = val, np.full(V.shape, s, dtype=np.int8)
                else:
                    better = val > best
                    arg = np.where(better, s, arg)
                    best = np.where(better, val, best)
            acc += best
            if n == 0:
                usign[i] = arg
        V = V + lam * acc
        V[boundary] = 0.0
        if n % store_every == 0:
            stored[n] = V.copy()
    times = sorted(stored)
    return {"t": np.round(np.array(times, dtype=float) * p.dt, 12),
            "V": np.stack([stored[k] for k in times]),
            "axis": g, "in_q": in_q, "boundary": boundary, "u_sign_t0": usign,
            "cfl": cfl_number(p)}


def node_index(p: BellmanParams, w) -> tuple:
    """Grid index of a point that lies on the grid (raises ConfigError otherwise)."""
    idx = []
    for x in w:
        k = x / p.h
        if abs(k - round(k)) > 1e-9 or abs(round(k)) > p.n_dom:
            raise ConfigError("bellman.points", list(w), "point must be a node of the grid")
        idx.append(int(round(k)) + p.n_dom)
    return tuple(idx)


def value_at(sol: dict, p: BellmanParams, w) -> np.ndarray:
    """V(t, w) at a grid node for every stored time."""
    i = node_index(p, w)
    return sol["V"][(slice(None),) + i]


def sup_on_slice(sol: dict, p: BellmanParams, wx: float = 0.0) -> np.ndarray:
    """p(t) = sup over (wy, wz) of V(t, wx, wy, wz) (wx a grid value)."""
    i = node_index(p, (wx, 0.0, 0.0))[0]
    return sol["V"][:, i].reshape(len(sol["t"]), -1).max(axis=1)


def monotonicity_report(sol: dict) -> dict:
    V = sol["V"]
    return {"V_min": float(V.min()), "V_max": float(V.max()),
            "in_unit_interval": bool(V.min() >= 0.0 and V.max() <= 1.0),
            # backwards in time V can only decrease (more time to leave Q)
            "nonincreasing_backwards": bool(np.all(np.diff(V, axis=0) >= -1e-15)),
            "cfl": sol["cfl"]}


def closed_loop(sol: dict, p: BellmanParams, w0, grad_zero_tol: float = 1e-12, rtol=1e-10) -> dict:
    """Simulate w' = f(w) + b*sign(grad V(t, w)) with the gradient of the stored V (central
    differences, trilinear interpolation), held constant over each time step dt (zero-order
    hold) and integrated with scipy's Dormand-Prince 5(4) (RK45)."""
    g = sol["axis"]
    t_grid = sol["t"]
    if len(t_grid) != p.n_steps + 1:
        raise ValueError("closed_loop needs V stored at every time step (store_every=1)")
    c = p.coeffs
    b = np.array(p.b)

    def f(t, w, u):
        return [c[0] * w[1] * w[2] + u[0], c[1] * w[2] * w[0] + u[1], c[2] * w[0] * w[1] + u[2]]

    w = np.asarray(w0, float)
    ts, ws, us = [0.0], [w.copy()], []
    for n in range(p.n_steps):
        grad = np.stack(np.gradient(sol["V"][n], p.h), axis=-1)           # central differences
        gi = RegularGridInterpolator((g, g, g), grad, bounds_error=False, fill_value=0.0)(w)[0]
        u = b * np.where(np.abs(gi) > grad_zero_tol, np.sign(gi), 0.0)
        r = solve_ivp(f, (t_grid[n], t_grid[n + 1]), w, method="RK45", args=(u,), rtol=rtol,
                      atol=1e-14)
        w = r.y[:, -1]
        ts.append(t_grid[n + 1])
        ws.append(w.copy())
        us.append(u)
    ws = np.array(ws)
    return {"t": np.array(ts), "w": ws, "u": np.array(us),
            "max_abs_w": float(np.max(np.abs(ws))),
            "stays_in_Q": bool(np.all(np.abs(ws) <= p.q + 1e-12)),
            "norm_w": np.linalg.norm(ws, axis=1)}


# --------------------------------------------------------------------------------------------
# Figures (returned, saved by the caller)
# --------------------------------------------------------------------------------------------
def plot_level_sets(rows, levels):
    """Level sets of V(t, 0, wy, wz). ``rows``: list of (sol, params, times) - one figure row
    per solution (e.g. the T = 1 s solution and the longer closed-loop horizon)."""
    import matplotlib.pyplot as plt

    ncol = max(len(r[2]) for r in rows)
    fig, axes = plt.subplots(len(rows), ncol, figsize=(3.6 * ncol + 1.0, 3.5 * len(rows)),
                             squeeze=False, constrained_layout=True)
    for ax_row, (sol, p, times) in zip(axes, rows):
        g = sol["axis"]
        i0 = node_index(p, (0.0, 0.0, 0.0))[0]
        for ax, t in zip(ax_row, times):
            k = int(np.argmin(np.abs(sol["t"] - t)))
            Z = sol["V"][k, i0]
            cs = ax.contourf(g, g, Z.T, levels=np.linspace(0, 1, 21), cmap="viridis")
            ax.contour(g, g, Z.T, levels=levels, colors="w", linewidths=0.7)
            ax.add_patch(plt.Rectangle((-p.q, -p.q), 2 * p.q, 2 * p.q, fill=False, ec="r", lw=0.8))
            ax.set_title(f"T = {p.horizon:g} s: V(t={sol['t'][k]:.1f} s, 0, wy, wz)", fontsize=8)
            ax.set_xlabel("wy, rad/s", fontsize=8)
            ax.set_ylabel("wz, rad/s", fontsize=8)
            ax.tick_params(labelsize=7)
            ticks = np.round(np.linspace(-p.q, p.q, 5), 6)
            ax.set_xticks(ticks)
            ax.set_yticks(ticks)
            ax.set_aspect("equal")
        for ax in ax_row[len(times):]:
            ax.axis("off")
    fig.colorbar(cs, ax=axes.ravel().tolist(), shrink=0.8, label=f"V (white: levels {levels})")
    return fig


def plot_points(t, series: dict, title):
    """V(t) at given points (left) and 1 - V(t) on a log scale (right), so that departures from
    1 smaller than the line width stay visible."""
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    for (label, v), ls in zip(series.items(), ("-", "--", ":", "-.")):
        ax.plot(t, v, ls, marker="o", ms=3, label=label)
        ax2.semilogy(t, np.maximum(1.0 - np.asarray(v), 1e-17), ls, marker="o", ms=3, label=label)
    ax.set_ylabel("V(t, w)")
    ax.set_ylim(-0.02, 1.05)
    ax2.set_ylabel("1 - V(t, w)  (floored at 1e-17)")
    for a in (ax, ax2):
        a.set_xlabel("t, s")
        a.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return fig


def plot_sup(t, pt, title):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(t, pt, "o-", ms=3)
    ax.set_xlabel("t, s")
    ax.set_ylabel("p(t) = sup V(t, 0, wy, wz)")
    ax.set_ylim(-0.02, 1.05)
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    return fig


def plot_closed_loop(runs: dict, p: BellmanParams):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(runs), 2, figsize=(11, 3.4 * len(runs)), squeeze=False)
    for row, (label, r) in zip(axes, runs.items()):
        for i, name in enumerate(("wx", "wy", "wz")):
            row[0].plot(r["t"], r["w"][:, i], label=name)
            row[1].step(r["t"][:-1], r["u"][:, i] / p.b[i] + 0.05 * (i - 1), where="post", label=f"u{name[1]}/b")
        row[0].axhline(p.q, color="r", lw=0.7, ls="--")
        row[0].axhline(-p.q, color="r", lw=0.7, ls="--", label="box Q")
        row[0].set_title(f"closed loop from {label}: max|w_i| = {r['max_abs_w']:.4f} rad/s", fontsize=9)
        row[0].set_ylabel("w, rad/s")
        row[1].set_ylabel("u_i / b_i (offset for legibility)")
        row[0].legend(fontsize=7)
        row[1].legend(fontsize=7)
        for a in row:
            a.grid(alpha=0.3)
            a.set_xlabel("t, s")
    fig.tight_layout()
    return fig
