"""``bootnav process`` end to end through the real console entry point, on a real canonical IMU file."""

from __future__ import annotations

import csv
import json
import subprocess
import sys

import h5py
import numpy as np
import pytest

from tests.conftest import REPO

SHORT = "xio_ngimu_loops/short_walk/imu.csv.gz"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def bootnav(*args, timeout=240):
    return subprocess.run([sys.executable, "-m", "bootnav.cli", "process", *map(str, args)], capture_output=True,
                          text=True, timeout=timeout, cwd=REPO)


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], np.array(rows[1:], dtype=float)


@pytest.fixture(scope="module")
def cli_run(tmp_path_factory):
    from tests.conftest import DATASETS

    src = DATASETS / SHORT
    if not src.exists():
        pytest.skip(f"dataset {src} not found")
    out = tmp_path_factory.mktemp("cli") / "out"
    proc = bootnav(src, "--out", out, "--closed-loop", "--geo-anchor", "48.137,11.575,520")
    assert proc.returncode == 0, proc.stderr
    return src, out, proc


def test_every_output_file_with_documented_columns(cli_run):
    src, out, proc = cli_run
    header, traj = read_csv(out / "trajectory.csv")
    assert header == ["t_s", "x_m", "y_m", "z_m", "vx_mps", "vy_mps", "vz_mps", "stance", "qw", "qx", "qy", "qz",
                      "sensor_yaw_enu_rad", "sensor_heading_deg_cw_from_north"]
    n_input = sum(1 for _ in __import__("gzip").open(src, "rt")) - 1
    assert len(traj) == n_input  # one row per input sample, nothing dropped
    assert np.all(np.diff(traj[:, 0]) >= 0) and set(np.unique(traj[:, 7])) == {0.0, 1.0}
    header, steps = read_csv(out / "steps.csv")
    assert header == ["t_s", "x_m", "y_m", "z_m", "stride_length_m", "dz_m", "yaw_enu_rad",
                      "heading_deg_cw_from_north", "quality_flags", "floor", "ellipse_major_m", "ellipse_minor_m",
                      "ellipse_orientation_rad"]
    assert len(steps) >= 12
    # quality flags: a bitmask of the implausibility flags (summary "navigation.stride_flag_bits"); kept strides
    # are never "tiny" (bit 16)
    flags = steps[:, 8].astype(int)
    assert np.all(flags >= 0) and np.all(flags & 16 == 0)
    # stride k goes from footprint k-1 to footprint k (4-decimal CSV rounding: 1e-3 m tolerance)
    assert np.allclose(steps[1:, 4], np.hypot(*np.diff(steps[:, 1:3], axis=0).T), atol=1e-3)
    assert np.allclose(steps[1:, 5], np.diff(steps[:, 3]), atol=1e-3)
    assert np.all(np.abs(steps[:, 6]) <= np.pi + 1e-6)
    for k in range(1, 8):
        png = list(out.glob(f"{k}_*.png"))
        assert len(png) == 1, f"chart {k} missing"
        data = png[0].read_bytes()
        assert data[:8] == PNG_MAGIC and len(data) > 20_000  # a real drawing, not an empty canvas
    page = (out / "path.html").read_text()
    assert page.count("<title>stride ") == len(steps) and "<polyline" in page  # one hover dot per stride
    with h5py.File(out / "results.h5") as f:
        assert f["results/default/pos_n_m"].shape == (len(traj), 3)
        assert f["imu/t_s"].shape[0] == len(traj)


def test_summary_json(cli_run):
    _, out, proc = cli_run
    s = json.loads((out / "summary.json").read_text())
    for key in ("distance_m", "closure_pct", "floors_climbed", "floors_descended", "settings", "software",
                "timings_s", "conventions", "warnings", "saturation_intervals", "files", "metrics"):
        assert key in s, key
    assert s["conventions"]["nav_frame"].startswith("ENU")
    # closed loop (truth): closure bound from the paper's best Table 1 error (2.5 % of the distance)
    assert s["metrics"]["closure_pct"] < 2.5
    # the passes (passes.BlockPasses): load (checks, calibration), the noise floor, the timing probes, the final pass
    assert set(s["timings_s"]) >= {"load", "stance_floor", "timing", "navigation", "strides", "write", "plots"}
    assert "closure" in proc.stdout and "distance" in proc.stdout
    assert "navigation done" in proc.stderr  # progress goes to stderr, results to stdout


def test_geojson_local_and_anchored(cli_run, tmp_path):
    _, out, _ = cli_run
    gj = json.loads((out / "path.geojson").read_text())
    assert gj["type"] == "FeatureCollection" and "WGS-84" in gj["properties"]["crs"]
    line = np.array(gj["features"][0]["geometry"]["coordinates"])
    steps = read_csv(out / "steps.csv")[1]
    # 1 deg latitude ~ 111.2 km: the path (+-8 m) must stay within ~1e-4 deg of the anchor
    assert np.all(np.abs(line[:, 1] - 48.137) < 1.5e-4) and np.all(np.abs(line[:, 0] - 11.575) < 2e-4)
    # north-south extent of the footprints: metres per degree of latitude at 48.137 deg = 111,210 m
    extent_m = (line[:, 1].max() - line[:, 1].min()) * 111_210
    y = np.concatenate(([0.0], steps[:, 2]))
    assert extent_m == pytest.approx(y.max() - y.min(), rel=0.003, abs=2e-3)
    assert line[0, 2] == pytest.approx(520.0)


def test_settings_file_and_overrides_are_recorded(tmp_path, datasets):
    settings = tmp_path / "s.json"
    settings.write_text(json.dumps({"floor_height_m": 2.7, "filter": {"n_states": 15}}))
    ref = tmp_path / "ref.json"
    ref.write_text(json.dumps({"straight_m": 9}))
    out = tmp_path / "o"
    proc = bootnav(datasets / SHORT, "--out", out, "--settings", settings, "--mode", "riccati", "--states", "9",
                   "--crop", "0", "22", "--reference", ref, "--no-plots", "--detector", "shoe", "--threshold", "3e6",
                   "--save-settings", tmp_path / "used.json", "-q")
    assert proc.returncode == 0, proc.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["settings"]["floor_height_m"] == 2.7
    assert s["settings"]["filter"]["mode"] == "riccati" and s["settings"]["filter"]["n_states"] == 9
    assert s["settings"]["crop_s"] == [0.0, 22.0] and s["input"]["t_end_s"] <= 22.0
    assert s["settings"]["detector"]["method"] == "shoe" and s["stance"]["method"] == "shoe"
    assert s["metrics"]["reference_kind"] == "straight" and "deviation_error_pct" in s["metrics"]
    assert json.loads((tmp_path / "used.json").read_text()) == s["settings"]
    assert not list(out.glob("*.png"))
    assert proc.stderr == ""  # -q


def test_bad_input_exits_1_with_a_clear_message(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\n" +
                   "".join(f"{i / 100},0,0,9.8,0,0,0\n" for i in range(50)))
    proc = bootnav(bad, "--out", tmp_path / "o", "-q")
    assert proc.returncode == 1
    assert proc.stderr.startswith("bootnav process: error: ") and "bad.csv" in proc.stderr
    assert "Traceback" not in proc.stderr
    proc = bootnav(tmp_path / "nope.h5", "--out", tmp_path / "o")
    assert proc.returncode == 1 and "nope.h5: no such file" in proc.stderr
    proc = bootnav(bad, "--out", tmp_path / "o", "--settings", tmp_path / "missing.json")
    assert proc.returncode == 1 and "settings file not found" in proc.stderr


def test_parser_stays_light():
    """`bootnav --help` builds every subcommand's parser: ours must not import numpy/numba/matplotlib."""
    code = ("import sys, argparse\nimport bootnav.postproc.cli_process as c\nc.add_arguments(argparse.ArgumentParser())\n"
            "print(','.join(m for m in ('numpy', 'numba', 'matplotlib', 'scipy', 'h5py') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == ""


def test_several_inputs_in_parallel_one_bad(tmp_path, datasets):
    bad = tmp_path / "bad.csv"
    bad.write_text("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\n0,0,0,9.8,0,0,0\n")
    proc = bootnav(datasets / SHORT, bad, "--out", tmp_path / "o", "--no-plots", "--crop", "0", "25", "--jobs", "2")
    assert proc.returncode == 1  # one input failed: said so, the other one is complete
    assert "bad.csv" in proc.stderr and "1 of 2 inputs processed" in proc.stdout
    s = json.loads((tmp_path / "o" / "imu" / "summary.json").read_text())
    assert s["input"]["source"].endswith(SHORT) and s["path"]["strides"] > 5


def test_output_names_are_distinct():
    from bootnav.postproc.cli_process import output_names

    assert output_names(["/a/x/imu.csv.gz", "/a/y/imu.csv.gz"]) == ["x_imu", "y_imu"]
    assert output_names(["/d/walk1.h5", "/d/walk2.h5"]) == ["walk1", "walk2"]
    assert len(set(output_names(["/p/a/s/imu.csv.gz", "/p/b/s/imu.csv.gz"]))) == 2


def test_bundled_recording_with_its_reference(tmp_path):
    """The repository's own example recording (no shared datasets needed, so this runs on a clean CI),
    processed: the recording is left byte for byte as it was, the results go to OUT/results.h5
    (the recording + /results), reopened by a fresh process."""
    src = REPO / "recordings" / "xio_ngimu_short_walk.h5"
    if not src.exists():
        pytest.skip("recordings/ not present")
    rec = tmp_path / "walk.h5"  # a copy: a regression must not damage the repository's file
    rec.write_bytes(src.read_bytes())
    before = rec.read_bytes()
    ref = src.with_name("xio_ngimu_short_walk.reference.json")
    proc = bootnav(rec, "--out", tmp_path / "o", "--reference", ref, "--no-plots", "--results-name", "demo", "-q")
    assert proc.returncode == 0, proc.stderr
    assert rec.read_bytes() == before
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["metrics"]["reference_kind"] == "closed_loop"
    assert s["metrics"]["closure_pct"] < 2.5  # closed loop (truth); the paper's best Table 1 error is 2.5 %
    code = ("import sys, h5py, json\nf = h5py.File(sys.argv[1], 'r')\n"
            "print(json.dumps([f['results/demo/pos_n_m'].shape[0], f['imu/t_s'].shape[0]]))")
    from tests.conftest import run_python

    n_pos, n_imu = json.loads(run_python(code, str(tmp_path / "o" / "results.h5")).stdout)
    assert n_pos == n_imu


# ------------------------------------------------------------------ honest outputs (issue 13, point 5)
@pytest.fixture(scope="module")
def bundled_open(tmp_path_factory):
    """The bundled loop processed without a reference: nothing says it is a loop."""
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    rec = REPO / "recordings" / "xio_ngimu_short_walk.h5"
    if not rec.exists():
        pytest.skip("recordings/ not present")
    return process(rec, ProcessSettings(crop_s=(0.0, 30.0)))


def test_closure_only_for_a_closed_loop_in_every_output(bundled_open, tmp_path):
    from bootnav.postproc.cli_process import format_summary
    from bootnav.postproc.outputs import write_outputs
    from bootnav.postproc.reference_path import load_reference
    from bootnav.postproc.summary import is_closed_loop

    r = bundled_open
    files = write_outputs(r, tmp_path / "open")
    text = format_summary(r.summary, files).split("\nfiles")[0]
    assert r.summary["closed_loop"] is False and "closure" not in text and "end − start" in text
    assert "end − start" in (tmp_path / "open" / "path.html").read_text().split("</h3>")[0]
    assert json.loads((tmp_path / "open" / "summary.json").read_text())["closed_loop"] is False
    loop = load_reference('{"waypoints": [[0, 0], [10, 0], [10, 5], [0, 5], [0, 0.2]]}')
    assert is_closed_loop(load_reference('{"closed_loop": true}')) and is_closed_loop(loop)
    assert not is_closed_loop(load_reference('{"straight_m": 9}')) and not is_closed_loop(None)
    r.summary["closed_loop"] = True
    assert "closure" in format_summary(r.summary, files)


def test_geojson_only_with_a_geo_anchor(bundled_open, tmp_path):
    """Local metres in a GeoJSON file are drawn by GIS tools at 0° N 0° E: no file without an anchor."""
    from bootnav.postproc.outputs import write_outputs

    r = bundled_open
    r.settings.output.plots = False
    try:
        files = write_outputs(r, tmp_path / "a")
        assert "geojson" not in files and not (tmp_path / "a" / "path.geojson").exists()
        r.settings.output.geo_anchor = (48.137, 11.575)
        files = write_outputs(r, tmp_path / "b")
        assert "WGS-84" in json.loads((tmp_path / "b" / "path.geojson").read_text())["properties"]["crs"]
    finally:
        r.settings.output.plots, r.settings.output.geo_anchor = True, None


def test_reference_drawn_in_the_estimate_frame():
    """The reference on the time charts: ``align_to_reference`` took the estimate onto the reference; mapping
    the reference back must land on an estimate that is the reference rotated and moved (exactly)."""
    from bootnav.postproc.plots import reference_in_estimate_frame
    from bootnav.postproc.reference_path import Reference, align_to_reference

    t = np.linspace(0, 10, 201)
    ref = np.column_stack((t, np.sin(t), 0.1 * t))
    yaw, start = 0.7, np.array([2.0, -1.0, 0.5])
    c, s = np.cos(yaw), np.sin(yaw)
    est = np.column_stack((c * ref[:, 0] - s * ref[:, 1], s * ref[:, 0] + c * ref[:, 1], ref[:, 2])) + start
    _, ref_pts, yaw_found = align_to_reference(Reference("trajectory", ref, t_s=t, has_z=True), t, est)
    assert np.allclose(reference_in_estimate_frame(ref_pts, yaw_found, est[0]), est, atol=1e-9)


def test_waist_sensor_is_flagged_foot_is_not(bundled_open, datasets):
    """A lower-back IMU run through the foot pipeline gets a warning naming the likely mount (Voisard 1-1:
    a 0.55 s step rhythm, ‖ω‖ below 3 rad/s, centimetres of path); the bundled foot walk gets none."""
    from bootnav.postproc.pipeline import process

    lower_back = datasets / "voisard_ipol" / "1-1" / "imu_lowerback.csv.gz"
    if not lower_back.exists():
        pytest.skip(f"{lower_back} not present")
    r = process(lower_back)
    assert r.summary["mount"]["looks_like_foot"] is False
    assert any("does not look like a sensor on a foot" in w and "bootnav pdr" in w for w in r.warnings)
    assert bundled_open.summary["mount"]["looks_like_foot"] is True
    assert not any("foot" in w for w in bundled_open.warnings)
