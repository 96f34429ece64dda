"""The documented Python API (issue 13, point 3): ``bootnav.load``, ``bootnav.process`` (path, recording or
arrays), ``bootnav.pdr``, DataFrames with pandas optional, a light ``import bootnav``, and the README's
example file executed as it is."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import bootnav
from bootnav.errors import InputError
from tests.conftest import REPO

BUNDLED = REPO / "recordings" / "xio_ngimu_short_walk.h5"


@pytest.fixture(scope="module")
def rec():
    if not BUNDLED.exists():
        pytest.skip("recordings/ not present")
    return bootnav.load(BUNDLED)


def test_import_bootnav_is_light():
    code = ("import sys, json, bootnav\n"
            "light = [m for m in ('numpy', 'h5py', 'scipy', 'bootnav.api') if m in sys.modules]\n"
            "bootnav.process\n"
            "print(json.dumps([light, 'bootnav.api' in sys.modules, sorted(bootnav.__all__)]))")
    light, loaded, names = json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                                     check=True, cwd=REPO).stdout)
    assert light == [] and loaded
    assert {"load", "process", "pdr", "CONVENTIONS"} <= set(names)
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        bootnav.nope  # noqa: B018


def test_arrays_in_gives_the_same_path_as_the_file(rec):
    """The arrays form is the same pipeline: bit-identical path and strides for the same samples."""
    by_path = bootnav.process(BUNDLED, crop_s=(0.0, 25.0))
    by_arrays = bootnav.process(rec.t_s, rec.acc_mps2, rec.gyro_radps, crop_s=(0.0, 25.0))
    assert by_path.t_s[-1] <= 25.0
    assert np.array_equal(by_path.pos_n_m, by_arrays.pos_n_m)
    assert np.array_equal(by_path.steps["stride_length_m"], by_arrays.steps["stride_length_m"])
    assert by_arrays.summary["strides"] == len(by_arrays.steps["t_s"]) > 5
    # both heading columns, one direction: compass = (90 - degrees(yaw)) mod 360
    st = by_arrays.steps
    assert np.allclose(st["heading_deg_cw_from_north"], np.mod(90 - np.degrees(st["yaw_enu_rad"]), 360))


def test_settings_as_keywords_dicts_and_objects(rec):
    from bootnav.postproc.settings import ProcessSettings

    r = bootnav.process(rec, reference='{"closed_loop": true}', filter={"smoother": "none"})
    used = r.raw.settings.filter
    assert used.smoother == "none" and used.n_states == ProcessSettings().filter.n_states  # the rest: defaults
    assert r.metrics["reference_kind"] == "closed_loop" and r.metrics["closure_pct"] < 2.5  # the paper's best: 2.5 %
    with pytest.raises(InputError, match="nonsense"):
        bootnav.process(rec, nonsense=1)
    with pytest.raises(InputError, match=r"acc_mps2 \(N, 3\)"):
        bootnav.process(rec.t_s, rec.acc_mps2[:, :2], rec.gyro_radps)


def test_dataframes_and_a_clear_error_without_pandas(rec, monkeypatch):
    pd = pytest.importorskip("pandas")
    r = bootnav.process(rec, crop_s=(0.0, 20.0))
    df = r.to_dataframe()
    assert df.index.name == "t_s" and list(df.columns)[:7] == ["x_m", "y_m", "z_m", "vx_mps", "vy_mps", "vz_mps", "stance"]
    assert len(df) == len(r.t_s) and np.array_equal(df["z_m"].to_numpy(), r.pos_n_m[:, 2])
    assert isinstance(r.steps_dataframe(), pd.DataFrame) and len(r.steps_dataframe()) == r.summary["strides"]
    monkeypatch.setitem(sys.modules, "pandas", None)  # as if not installed
    with pytest.raises(ImportError, match="needs pandas"):
        r.to_dataframe()


def test_pdr_from_arrays_and_from_a_file(rec):
    a = bootnav.pdr(rec.t_s, rec.acc_mps2, rec.gyro_radps, heading="gyro")
    b = bootnav.pdr(BUNDLED, heading="gyro")
    assert a.heading_source == "gyro" and len(a.t_s) >= 10
    assert np.array_equal(a.length_m, b.length_m)
    assert list(a.to_dataframe().reset_index().columns) == ["t_s", "length_m", "yaw_enu_rad", "heading_deg_cw_from_north",
                                              "x_m", "y_m"]


def test_the_documented_example_runs(tmp_path):
    proc = subprocess.run([sys.executable, str(REPO / "docs" / "api-example.py"), str(tmp_path / "out")],
                          capture_output=True, text=True, timeout=180, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "PathResult(" in proc.stdout and "StepResult(" in proc.stdout
    assert (tmp_path / "out" / "summary.json").exists() and (tmp_path / "out" / "results.h5").exists()
