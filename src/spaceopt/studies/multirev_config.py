"""The ``multirev`` section of the config (dissertation §4.1) turned into transfers and checked.

Physical inputs carry their units in the key names (``*_km``, ``*_deg``, ``*_kg``, ``*_s``,
``*_N``); each value is checked here and a bad one is a one-line ConfigError naming its key. The
module imports no solver (diffrax, optimistix, the chain): the Snakefile runs :func:`check_config`
when it plans the DAG, and every Snakemake run pays for what it imports.
"""
from __future__ import annotations

import math

from ..elements import apsides_to_ae
from ..errors import ConfigError
from ..indirect.transfer import Orbit, Transfer


ORBIT_KEYS = ("perigee_alt_km", "apogee_alt_km", "i_deg", "raan_deg", "argp_deg")


def number(cfg, key, path, positive=False, allow_zero=False):
    """``cfg[key]`` as a finite float (positive where asked); ``path`` names the mapping in errors."""
    if key not in cfg:
        raise ConfigError(f"{path}.{key}", None, "missing (give the value with the unit in the key name)")
    val = cfg[key]
    if isinstance(val, bool) or not isinstance(val, (int, float)) or not math.isfinite(val):
        raise ConfigError(f"{path}.{key}", val, "must be a finite number")
    if positive and not (val > 0 or (allow_zero and val == 0)):
        raise ConfigError(f"{path}.{key}", val, "must be positive")
    return float(val)


def positive_integer(val, path):
    """``val`` checked to be a positive integer (not a bool); ``path`` names its key in the error."""
    if not isinstance(val, int) or isinstance(val, bool) or val < 1:
        raise ConfigError(path, val, "must be a positive integer")
    return val


def orbit_from_config(cfg, path, radius_m) -> Orbit:
    if not isinstance(cfg, dict):
        raise ConfigError(path, cfg, "must be a mapping of orbit elements")
    unknown = sorted(set(cfg) - set(ORBIT_KEYS))
    if unknown:
        raise ConfigError(f"{path}.{unknown[0]}", cfg[unknown[0]],
                          f"unknown key (expected {', '.join(ORBIT_KEYS)}; units in the key name)")
    hp = number(cfg, "perigee_alt_km", path) * 1e3
    ha = number(cfg, "apogee_alt_km", path) * 1e3
    if ha < hp:
        raise ConfigError(f"{path}.apogee_alt_km", cfg["apogee_alt_km"], "apogee below perigee")
    if radius_m + hp <= 0:
        raise ConfigError(f"{path}.perigee_alt_km", cfg["perigee_alt_km"], "perigee inside the Earth's centre")
    a, e = apsides_to_ae(hp, ha, radius_m)
    return Orbit(a, e, number(cfg, "i_deg", path), cfg.get("raan_deg", 0.0), cfg.get("argp_deg", 0.0))


def transfer_from_config(mr: dict, case: str, isp_s: float | None = None, thrust_N: float | None = None) -> Transfer:
    """Build the Transfer of ``multirev.cases.<case>`` (validating every physical input)."""
    if case not in mr.get("cases", {}):
        raise ConfigError("multirev.cases", case, "unknown case")
    cc = mr["cases"][case]
    path = f"multirev.cases.{case}"
    const = mr["constants"]
    radius = number(const, "earth_radius_km", "multirev.constants", positive=True) * 1e3
    mu = number(const, "mu_km3_s2", "multirev.constants", positive=True) * 1e9
    orbits = mr["orbits"]
    for end in ("initial", "final"):
        if cc.get(end) not in orbits:
            raise ConfigError(f"{path}.{end}", cc.get(end), "unknown orbit name")
    sc = mr["spacecraft"]
    n_rev = number(cc, "n_rev", path, positive=True)
    isp = isp_s if isp_s is not None else number(sc, "isp_s", "multirev.spacecraft", positive=True)
    return Transfer(orbit_from_config(orbits[cc["initial"]], f"multirev.orbits.{cc['initial']}", radius),
                    orbit_from_config(orbits[cc["final"]], f"multirev.orbits.{cc['final']}", radius),
                    L0_deg=number(cc, "L0_deg", path), n_rev=n_rev,
                    m0=number(sc, "m0_kg", "multirev.spacecraft", positive=True), isp=isp,
                    thrust=float("nan") if thrust_N is None else thrust_N, mu=mu,
                    eps_final=number(mr["numerics"], "eps_final", "multirev.numerics", positive=True),
                    eps_blend=number(mr["numerics"], "eps_blend", "multirev.numerics", positive=True))


def check_config(mr: dict) -> None:
    """Physical checks of the multirev section: every case to run builds a valid Transfer."""
    for i, case in enumerate(mr["run_cases"]):
        if case not in mr["cases"]:
            raise ConfigError(f"multirev.run_cases[{i}]", case, "unknown case")
        cc = mr["cases"][case]
        for isp in cc["tmin_isp_s"]:
            transfer_from_config(mr, case, isp_s=isp)
        for T in cc["ot_thrust_N"]:
            transfer_from_config(mr, case, thrust_N=T)
    t413 = mr["table_4_1_3"]
    if t413["case"] not in mr["cases"]:
        raise ConfigError("multirev.table_4_1_3.case", t413["case"], "unknown case")
    if t413["anchor_N"] not in t413["thrust_N"]:
        raise ConfigError("multirev.table_4_1_3.anchor_N", t413["anchor_N"], "must be one of thrust_N")
