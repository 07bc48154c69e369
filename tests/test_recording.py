"""Rerun recordings: write a small trajectory with the SDK and read it back (rerun-sdk 0.41)."""
import numpy as np
import pytest

pytest.importorskip("rerun", reason="rerun-sdk is a pinned dependency; install the environment with ./dev setup")

from spaceopt.errors import ArtifactError, ConfigError  # noqa: E402
from spaceopt.report.recording import _arcs, read_recording, scalar_series, write_trajectory_recording  # noqa: E402


def _toy(n=60):
    t = np.linspace(0.0, 6000.0, n)
    r = 7000.0 * np.c_[np.cos(t / 1000), np.sin(t / 1000), 0.01 * t / 1000]
    burn = np.zeros(n, bool)
    burn[5:20] = True
    burn[40:50] = True
    series = {"mass_kg": 1000.0 - 0.001 * t, "thrust_N": np.where(burn, 0.25, 0.0),
              "switching_S": np.sin(t / 700)}
    return t, r, burn, series


def test_arcs_split_burns_and_coasts():
    mask = np.array([0, 1, 1, 0, 0, 1], bool)
    assert _arcs(mask) == [(1, 4), (5, 6)]
    assert _arcs(~mask) == [(0, 2), (3, 6)]
    assert _arcs(np.ones(3, bool)) == [(0, 3)]


def test_write_and_read_back(tmp_path):
    t, r, burn, series = _toy()
    path = write_trajectory_recording(tmp_path / "case" / "ot.rrd", t, r, burn, series)
    assert path.exists() and path.stat().st_size > 0
    assert not list(path.parent.glob(".*.tmp")), "temporary file left behind"
    rec = read_recording(path)
    # burn and coast arcs are separate static entities, one strip per contiguous arc
    assert rec["trajectory/burn"]["static"] and rec["trajectory/coast"]["static"]
    burn_strips = rec["trajectory/burn"]["LineStrips3D:strips"][0]
    coast_strips = rec["trajectory/coast"]["LineStrips3D:strips"][0]
    assert len(burn_strips) == 2 and len(coast_strips) == 3
    np.testing.assert_allclose(np.array(burn_strips[0]), r[5:21], rtol=1e-6)   # float32 in rerun
    # the spacecraft position on the time timeline
    sc = rec["trajectory/spacecraft"]
    np.testing.assert_allclose(sc["times"], t - t[0], atol=1e-6)
    np.testing.assert_allclose(np.array(sc["Points3D:positions"]).reshape(-1, 3), r, rtol=1e-6)
    # time series of mass, thrust and switching function
    for name, values in series.items():
        tt, v = scalar_series(rec, name)
        np.testing.assert_allclose(tt, t - t[0], atol=1e-6)
        np.testing.assert_allclose(v, values, rtol=1e-12, atol=1e-12)


def test_bad_inputs_are_one_line_errors(tmp_path):
    t, r, burn, series = _toy()
    with pytest.raises(ConfigError, match="recording.r"):
        write_trajectory_recording(tmp_path / "x.rrd", t, r[:, :2], burn)
    with pytest.raises(ConfigError, match="recording.series.mass_kg"):
        write_trajectory_recording(tmp_path / "x.rrd", t, r, burn, {"mass_kg": series["mass_kg"][:-1]})


def test_missing_or_corrupted_recording_is_detected(tmp_path):
    with pytest.raises(ArtifactError, match="missing"):
        read_recording(tmp_path / "nope.rrd")
    bad = tmp_path / "bad.rrd"
    bad.write_bytes(b"this is not a rerun recording" * 10)
    with pytest.raises(ArtifactError, match="unreadable"):
        read_recording(bad)


@pytest.mark.parametrize("fraction", [0.3, 0.95])
def test_truncated_recording_is_detected(tmp_path, fraction):
    t, r, burn, series = _toy()
    path = write_trajectory_recording(tmp_path / "ok.rrd", t, r, burn, series)
    data = path.read_bytes()
    cut = tmp_path / "cut.rrd"
    cut.write_bytes(data[: int(len(data) * fraction)])
    with pytest.raises(ArtifactError, match="truncated|unreadable"):
        read_recording(cut)
