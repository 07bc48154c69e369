"""Problem definitions of the peer benchmark against ESA pykep 3 (spec 06-peer-problems).

These are problem *definitions* (the data pykep's TOPS set and its mass-optimal example store),
not results: start and target modified equinoctial elements (Walker's (p, f, g, h, k, L) = our
(p, e_x, e_y, i_x, i_y, L)), μ, m0, maximum thrust, effective exhaust velocity, time of flight.
pykep's stored reference solutions are deliberately absent (spec 06: pykep's answer comes from
running pykep).

Every problem is kept in SI (P0 is stored nondimensional in pykep and is converted here with the
spec's units: 1 AU, μ = 1, time unit 5 022 642.890925519 s, mass unit 4000 kg) so that the
same numbers feed both our Transfer (SI at the boundary) and the pykep runner, which works in
the problem's own nondimensional units (see ``nondimensional``).

This module is plain Python + numpy (no JAX import) so that the pykep runner, which lives in a
separate environment without spaceopt, can import it too. E's Cartesian → MEE conversion is a
numpy copy of ``spaceopt.elements.cartesian_to_mee`` checked against it in
tests/test_peer_problems.py.
"""
from __future__ import annotations

import math

import numpy as np

G0 = 9.80665                     # m/s², standard gravity (c = Isp g0)
MU_SUN = 1.32712440018e20        # m³/s², the Jiang problems and E
AU = 149_597_870_700.0           # m
DAY = 86_400.0

# P0 nondimensional units (pykep's TOPS problem)
P0_TU = 5_022_642.890925519      # s
P0_MU = AU**3 / P0_TU**2         # μ = 1 in those units
P0_M0 = 4000.0                   # kg
P0_FU = P0_M0 * AU / P0_TU**2    # force unit [N]
P0_VU = AU / P0_TU               # velocity unit [m/s]

P0_START = (0.999694306527203, -0.003766786954568218, 0.016286832739416737,
            -7.70204556573997e-06, 6.183157574784651e-07, 1.5955219194574601)
P0_TARGET = (1.5537192000000046, 0.15302906960883775, -0.5199481742007107,
             0.01618310223871937, 0.11813952745106716, 33.76353813558095)

JIANG_START = (149654984885.8576, -0.003159967920532, 0.016705492433629,
               7.081860749e-06, 2.59372025e-06, 0.240005388978809)
JIANG_TARGET5 = (108204221662.18526, -0.004499485159298, 0.005049416150669,
                 0.006838004167958, 0.02883146394395)
JIANG_LF = {"P1": 14.611969791506613, "P2": 20.8951550986862,
            "P3": 27.178340405865786, "P4": 33.461525713045376}

E_R0 = (34110913367.783306, -139910016918.87585, -14037825669.025244)
E_V0 = (29090.9902134693, 10000.390168313803, 1003.3858682643288)
E_RF = (-159018773159.22266, -18832495968.945133, 15781467087.350443)
E_VF = (2781.182556622003, -28898.40730995848, -483.4533989771214)

ORDER = ("E", "P1", "P2", "P3", "P4", "P0")


def cartesian_to_mee_np(pos, vel, mu):
    """(r, v) → MEE, L in (−π, π] (numpy copy of spaceopt.elements.cartesian_to_mee)."""
    pos, vel = np.asarray(pos, float), np.asarray(vel, float)
    h = np.cross(pos, vel)
    hn = np.linalg.norm(h)
    p = hn**2 / mu
    ix = -h[1] / (hn + h[2])
    iy = h[0] / (hn + h[2])
    s2 = 1.0 + ix**2 + iy**2
    f_hat = np.array([1 + ix**2 - iy**2, 2 * ix * iy, -2 * iy]) / s2
    g_hat = np.array([2 * ix * iy, 1 - ix**2 + iy**2, 2 * ix]) / s2
    e_vec = np.cross(vel, h) / mu - pos / np.linalg.norm(pos)
    L = math.atan2(float(pos @ g_hat), float(pos @ f_hat))
    return np.array([p, e_vec @ f_hat, e_vec @ g_hat, ix, iy, L])


def _problem(name, source, start, target, mu, m0, thrust, c, tof, note=""):
    start, target = np.asarray(start, float), np.asarray(target, float)
    return {"name": name, "source": source, "note": note,
            "mee0": start.tolist(), "meef": target.tolist(),     # SI: p in m, angles in rad
            "mu_m3_s2": mu, "m0_kg": m0, "thrust_N": thrust, "c_m_s": c,
            "isp_s": c / G0, "tof_s": tof,
            "n_rev": (target[5] - start[5]) / (2 * math.pi)}


def problems() -> dict:
    """All problems in SI, keyed P0, P1–P4, E."""
    out = {}
    s0, sf = np.array(P0_START), np.array(P0_TARGET)
    s0[0] *= AU
    sf[0] *= AU
    out["P0"] = _problem("P0", "pykep TOPS: Earth to Dionysus (doi 10.2514/1.G000379)", s0, sf,
                         P0_MU, P0_M0, 0.013490919161437792 * P0_FU,
                         0.9877459715411968 * P0_VU, 60.79091977865148 * P0_TU,
                         "stored nondimensional (AU, mu = 1, TU = 5 022 642.89 s, 4000 kg)")
    for key, Lf in JIANG_LF.items():
        revs = {"P1": 2, "P2": 3, "P3": 4, "P4": 5}[key]
        out[key] = _problem(key, f"pykep TOPS: Jiang et al. (doi 10.2514/1.52476), {revs} revolutions",
                            JIANG_START, JIANG_TARGET5 + (Lf,), MU_SUN, 1500.0, 0.33, 37265.27,
                            86_400_000.0)
    m0 = cartesian_to_mee_np(E_R0, E_V0, MU_SUN)
    mf = cartesian_to_mee_np(E_RF, E_VF, MU_SUN)
    # zero full revolutions: the target longitude is the first one after the start
    mf[5] = m0[5] + math.remainder(mf[5] - m0[5], 2 * math.pi) % (2 * math.pi)
    out["E"] = _problem("E", "pykep pontryagin_equinoctial_mass documentation (easy case)", m0, mf,
                        MU_SUN, 1500.0, 0.6, 3000.0 * G0, 250.0 * DAY,
                        "Cartesian in the source; zero full revolutions")
    return {k: out[k] for k in ORDER}


def nondimensional(prob: dict) -> dict:
    """The problem in the units a pykep solve uses: L = 1 AU (P0) or p0 (others), μ = 1, m0 = 1.

    pykep's pontryagin_equinoctial_mass takes nondimensional data (its documented examples
    scale with L = AU, μ = 1, M = m0); any consistent choice gives the same optimum. We use AU
    for every problem (all are heliocentric).
    """
    L = AU
    TU = math.sqrt(L**3 / prob["mu_m3_s2"])
    VU = L / TU
    M = prob["m0_kg"]
    FU = M * L / TU**2
    scale = np.array([1 / L, 1, 1, 1, 1, 1])
    return {"L_m": L, "TU_s": TU, "VU_m_s": VU, "M_kg": M, "FU_N": FU,
            "mee0": (np.asarray(prob["mee0"]) * scale).tolist(),
            "meef": (np.asarray(prob["meef"]) * scale).tolist(),
            "mu": 1.0, "m0": 1.0, "thrust": prob["thrust_N"] / FU, "c": prob["c_m_s"] / VU,
            "tof": prob["tof_s"] / TU}
