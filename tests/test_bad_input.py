"""Bad input through the config and through the CLI: a one-line error naming the key and the
value, no traceback, nothing half-written (issue "software around the science", §4)."""
import copy
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from spaceopt import cli
from spaceopt.config import load_yaml, validate_section
from spaceopt.errors import ConfigError
from spaceopt.studies.multirev_config import check_config

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = ROOT / "config" / "schema" / "multirev.schema.yaml"
BASE = yaml.safe_load((ROOT / "config" / "studies" / "multirev.yaml").read_text())


def _set(cfg, path, value):
    node = cfg
    keys = path.split(".")
    for k in keys[:-1]:
        node = node[k]
    if value is _DELETE:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value
    return cfg


_DELETE = object()
HEO = "multirev.orbits.heo_500x60000_i7"
CONFIG_CASES = [
    # (path to change, new value, key expected in the message, value expected in the message)
    (f"{HEO}.i_deg", "seven", f"{HEO}.i_deg", "seven"),                       # non-numeric
    (f"{HEO}.apogee_alt_km", 100.0, f"{HEO}.apogee_alt_km", "100.0"),         # apogee < perigee
    (f"{HEO}.perigee_alt_km", -7000.0, f"{HEO}.perigee_alt_km", "-7000.0"),   # inside the Earth
    (f"{HEO}.perigee_alt", 500.0, f"{HEO}", "perigee_alt"),                   # missing unit
    (f"{HEO}.i_rad", 0.1, f"{HEO}", "i_rad"),                                 # wrong unit
    (f"{HEO}.i_deg", 190.0, f"{HEO}.i_deg", "190.0"),                         # out of range
    ("multirev.spacecraft.isp_s", -1520.0, "multirev.spacecraft.isp_s", "-1520.0"),
    ("multirev.spacecraft.m0_kg", 0.0, "multirev.spacecraft.m0_kg", "0.0"),
    ("multirev.cases.e1.n_rev", 0, "multirev.cases.e1.n_rev", "0"),           # zero revolutions
    ("multirev.cases.e1.ot_thrust_N", [-15.0], "multirev.cases.e1.ot_thrust_N.0", "-15.0"),
    ("multirev.run_cases", ["e1", "e7x"], "multirev.run_cases[1]", "e7x"),
    ("multirev.cases.e1.initial", "gto_nowhere", "multirev.cases.e1.initial", "gto_nowhere"),
    ("multirev.numerics.eps_final", 2.0, "multirev.numerics.eps_final", "2.0"),
    ("multirev.numerics.eps_final", "small", "multirev.numerics.eps_final", "small"),
    ("multirev.numerics.samples_per_rev", 12.5, "multirev.numerics.samples_per_rev", "12.5"),
    ("multirev.table_4_1_3.anchor_N", 0.33, "multirev.table_4_1_3.anchor_N", "0.33"),
    ("multirev.constants.mu_km3_s2", "398600", "multirev.constants.mu_km3_s2", "398600"),
    ("multirev.cases.e1.L0_deg", _DELETE, "multirev.cases.e1", "L0_deg"),    # missing key
]


@pytest.mark.parametrize("path,value,key,shown", CONFIG_CASES, ids=[c[0] + "=" + repr(c[1])[:12] for c in CONFIG_CASES])
def test_bad_config_gives_one_line_error(path, value, key, shown):
    cfg = _set(copy.deepcopy(BASE), path, value)
    with pytest.raises(ConfigError) as info:
        validate_section(cfg, "multirev", SCHEMA)
        check_config(cfg["multirev"])
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith(key), msg
    assert shown in msg, msg


def test_malformed_yaml_names_file_and_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("multirev:\n  orbits: [unclosed\n  x: 1\n")
    with pytest.raises(ConfigError) as info:
        load_yaml(bad)
    assert "bad.yaml" in str(info.value) and "line" in str(info.value) and "\n" not in str(info.value)


def test_unknown_perturbation_model_and_body():
    from spaceopt.forces import build_model
    with pytest.raises(ConfigError, match=r"perturbations.geopotential='j3'"):
        build_model({"geopotential": "j3"}, "2021-05-09T12:00:00")
    with pytest.raises(ConfigError, match=r"perturbations.third_bodies='mars'"):
        build_model({"third_bodies": ["mars"]}, "2021-05-09T12:00:00")


@pytest.mark.parametrize("value", [0, 2_000_000, 1.5e5])
def test_a_step_cap_outside_the_compiled_bound_is_one_line(value):
    """Transfer.max_steps is the traced cap of every propagation (.flow.StepCap), at most the
    static loop bound STEP_BOUND of the compiled programs: a cap above it is refused, not cut."""
    import dataclasses
    from spaceopt.indirect.transfer import STEP_BOUND, Orbit, Transfer
    tr = Transfer(Orbit(36621e3, 0.812375413, 7, 0, 178), Orbit(42164e3, 0, 0), 300, 2, 1000, 1520)
    assert dataclasses.replace(tr, max_steps=STEP_BOUND).max_steps == STEP_BOUND
    with pytest.raises(ConfigError) as info:
        dataclasses.replace(tr, max_steps=value)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"max_steps={value!r}") and str(STEP_BOUND) in msg, msg


def test_date_outside_the_ephemeris():
    from spaceopt.ephemeris import ChebyshevEphemeris, utc_to_tdb_seconds
    eph = ChebyshevEphemeris.from_de405("2021-05-01T00:00:00", "2021-05-20T00:00:00", "tiny")
    with pytest.raises(ConfigError, match=r"date='2021-07"):
        eph.check_time(utc_to_tdb_seconds("2021-07-01T00:00:00"))


GOOD = ["solve", "--initial", "a_km=36621,e=0.812375413,i_deg=7,argp_deg=178", "--final", "a_km=42164,e=0,i_deg=0",
        "--m0-kg", "1000", "--isp-s", "1520", "--thrust-n", "15", "--n-rev", "2", "--l0-deg", "300"]


def _with(option, value):
    argv = list(GOOD)
    argv[argv.index(option) + 1] = value
    return argv


CLI_CASES = [
    (_with("--initial", "a_km=36621,e=1.2,i_deg=7"), "initial.e", "1.2"),          # e >= 1
    (_with("--initial", "a_km=36621,e=-0.1,i_deg=7"), "initial.e", "-0.1"),
    (_with("--initial", "a_km=-36621,e=0.1,i_deg=7"), "initial.a", "-36621000.0"),
    (_with("--initial", "a=36621,e=0.1,i_deg=7"), "initial.a", "36621"),            # missing unit
    (_with("--initial", "a_km=36621,e=0.1,i_rad=0.1"), "initial.i_rad", "0.1"),     # wrong unit
    (_with("--initial", "a_km=36621,e=0.1"), "initial.i_deg", "None"),              # missing element
    (_with("--initial", "a_km=36621,e=0.1,i_deg=200"), "initial.i", "200.0"),
    (_with("--initial", "a_km=nan,e=0.1,i_deg=7"), "initial.a_km", "nan"),
    (_with("--initial", "a_km:36621"), "initial", "a_km:36621"),                    # malformed
    (_with("--final", "a_km=1000,e=0,i_deg=0"), "final.a_km", "1000.0"),            # inside the Earth
    (_with("--thrust-n", "-15"), "thrust_n", "-15"),                                # negative thrust
    (_with("--isp-s", "0"), "isp_s", "0"),
    (_with("--isp-s", "-1520"), "isp_s", "-1520"),
    (_with("--n-rev", "0"), "n_rev", "0"),                                          # zero revolutions
    (_with("--m0-kg", "abc"), "m0_kg", "abc"),                                      # non-numeric
    (_with("--l0-deg", "east"), "l0_deg", "east"),
    (GOOD + ["--mu-km3-s2", "-1"], "mu_km3_s2", "-1"),
    (GOOD + ["--eps-final", "2"], "eps_final", "2"),
    (GOOD + ["--geopotential", "j2"], "epoch_utc", "None"),                       # perturbed, no epoch
    (GOOD + ["--geopotential", "4by4", "--epoch-utc", "2021-05-09T12:00:00"], "geopotential", "4by4"),
    (GOOD + ["--geopotential", "8x8", "--epoch-utc", "2021-05-09T12:00:00"], "geopotential.degree", "8"),
    (GOOD + ["--third-bodies", "moon,mars", "--epoch-utc", "2021-05-09T12:00:00"], "third_bodies", "mars"),
    (GOOD + ["--third-bodies", "moon", "--epoch-utc", "2300-01-01T00:00:00"], "epoch_utc", "2300-01-01"),
    (GOOD + ["--geopotential", "j2", "--epoch-utc", "2021-13-09T12:00:00"], "epoch", "2021-13-09"),
    (GOOD + ["--geopotential", "4x4", "--earth-angle", "gmst", "--epoch-utc", "2021-05-09T12:00:00"],
     "earth_angle", "gmst"),
]


@pytest.mark.parametrize("argv,key,shown", CLI_CASES, ids=[f"{c[1]}={c[2]}" for c in CLI_CASES])
def test_bad_cli_input_gives_one_line_error(argv, key, shown, capsys, tmp_path):
    out = tmp_path / "out"
    rc = cli.main(argv + ["--out", str(out), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert rc == 1
    assert len(err.splitlines()) == 1 and err.startswith("error: "), err
    assert key in err and shown in err, err
    assert not out.exists()                   # nothing half-written


def test_cli_missing_argument_is_one_line(capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(["solve", "--final", "a_km=42164,e=0,i_deg=0"])
    assert info.value.code == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--initial" in err


def test_snakemake_reports_bad_config_in_one_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump({"multirev": {"spacecraft": {"m0_kg": 1000.0, "isp_s": -5.0}}}))
    snakemake = Path(sys.executable).with_name("snakemake")
    res = subprocess.run([str(snakemake), "-n", "--cores", "1", "--configfile", str(bad)],
                         cwd=ROOT, capture_output=True, text=True, timeout=120)
    lines = [ln for ln in res.stderr.splitlines() + res.stdout.splitlines()
             if ln.strip() and not ln.startswith("Config file")]
    assert res.returncode != 0
    assert "Traceback" not in res.stderr
    assert lines == ["error: multirev.spacecraft.isp_s=-5.0: -5.0 is less than or equal to the minimum of 0"], lines


def test_an_unquoted_date_in_the_config_is_named_with_the_quoted_form_to_write():
    """YAML reads ``skip_dates: [2021-05-20]`` as a date object, which the schema's string
    pattern rejects; the one-line error says how to write it."""
    import datetime
    root = Path(__file__).resolve().parents[1]
    cfg = {"perturbed": yaml.safe_load((root / "config/studies/perturbed.yaml").read_text())["perturbed"]}
    cfg["perturbed"]["e6"]["skip_dates"] = [datetime.date(2021, 5, 20)]
    with pytest.raises(ConfigError) as info:
        validate_section(cfg, "perturbed", root / "config/schema/perturbed.schema.yaml")
    msg = str(info.value)
    assert msg.startswith("perturbed.e6.skip_dates.0") and '(quote it: "2021-05-20")' in msg and "\n" not in msg
