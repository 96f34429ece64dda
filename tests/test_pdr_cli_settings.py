"""`bootnav pdr` reaches every PDR setting: settings files, detector/length parameters, heading methods,
magnetometer calibration and levelling, length calibration, checkpoints and the GPS comparison. Synthetic
level-phone walks (2 steps/s, known bearing and field) written as Physics Toolbox CSVs."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.postproc.pdr import PdrSettings, cli
from bootnav.postproc.pdr.heading.mag_calibration import calibrate_mag
from bootnav.postproc.pdr.heading.magnetometer import seed003_theta_deg, tilt_weight_heading, untilted_heading

G = 9.80665
B_ENU = np.array([0.0, 20.0, -40.0])  # uT: 20 north, 40 down
LAT0, LON0 = 46.66213, 32.63982


def _write_walk(path, bearing_deg=0.0, offset=(0.0, 0.0, 0.0), turn_s=0.0, rest=2.0, walk=20.0, fs=100.0,
                step_hz=2.0, step_m=0.7, gps=True):
    """Level phone, +y forward: rest, optional 360-deg turn on the spot, then a straight walk at
    ``step_hz`` with steps of ``step_m``; 1-Hz GPS fixes (none in the first 3 s)."""
    t = np.arange(0.0, rest + turn_s + walk, 1.0 / fs)
    t_walk = t - rest - turn_s
    az = G + np.where(t_walk >= 0, 2.5 * np.sin(2 * np.pi * step_hz * t_walk), 0.0)
    psi = np.radians(bearing_deg + np.where((t >= rest) & (t_walk < 0), 360.0 * (t - rest) / max(turn_s, 1e-9), 0.0))
    bx = B_ENU[0] * np.cos(psi) - B_ENU[1] * np.sin(psi)
    by = B_ENU[0] * np.sin(psi) + B_ENU[1] * np.cos(psi)
    mag = np.column_stack([bx, by, np.full_like(t, B_ENU[2])]) + np.asarray(offset)
    d = np.clip(t_walk, 0.0, None) * step_hz * step_m
    h = np.radians(bearing_deg)
    fix_t = np.floor(t)
    d_fix = np.interp(fix_t, t, d)
    lat = LAT0 + d_fix * np.cos(h) * 360 / 40e6
    lon = LON0 + d_fix * np.sin(h) * 360 / (40075696 * np.cos(np.radians(LAT0)))
    lat[t < 3.0] = lon[t < 3.0] = 0.0
    head = "time,gFx,gFy,gFz,wx,wy,wz,Bx,By,Bz" + (",Latitude,Longitude,Speed (m/s)" if gps else "")
    rows = [head] + [f"{t[i]:.3f},0,0,{az[i] / G:.5f},0,0,0,{mag[i, 0]:.3f},{mag[i, 1]:.3f},{mag[i, 2]:.3f}"
                     + (f",{lat[i]:.8f},{lon[i]:.8f},1.4" if gps else "") for i in range(t.size)]
    path.write_text("\n".join(rows) + "\n")
    return path


def _run(tmp_path, *argv, name="o"):
    p = argparse.ArgumentParser()
    cli.add_arguments(p)
    out = tmp_path / name
    assert cli.run(p.parse_args([*map(str, argv), "--no-plots", "--out", str(out)])) == 0
    return json.loads((out / "summary.json").read_text()), out


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    return _write_walk(tmp_path_factory.mktemp("w") / "walk.csv", bearing_deg=30.0)


def test_settings_file_roundtrip_and_precedence(tmp_path, walk):
    s1, _ = _run(tmp_path, walk, "--heading", "mag", "--detector", "peak_group", "--detector-param",
                 "local_distance_peaks_s=0.35", "--weinberg-k", "0.55", "--save-settings", tmp_path / "s.json", name="a")
    saved = json.loads((tmp_path / "s.json").read_text())
    assert saved["detector_params"] == {"local_distance_peaks_s": 0.35} and saved["length_params"] == {"k": 0.55}
    assert s1["detector_params"]["local_distance_peaks_s"] == 0.35
    s2, _ = _run(tmp_path, walk, "--settings", tmp_path / "s.json", name="b")
    assert s2["settings"] == s1["settings"] and s2["steps"] == s1["steps"] and s2["distance_m"] == s1["distance_m"]
    s3, _ = _run(tmp_path, walk, "--settings", tmp_path / "s.json", "--weinberg-k", "1.1", name="c")  # CLI wins
    assert s3["distance_m"] == pytest.approx(s1["distance_m"] * 1.1 / 0.55, rel=1e-9)
    # a summary.json of an earlier run, and a settings dict written before the new fields existed, load
    assert PdrSettings.from_file(tmp_path / "a" / "summary.json").to_dict() == s1["settings"]
    old = {k: v for k, v in PdrSettings().to_dict().items() if k not in ("mag_tilt", "mag_calibration",
                                                                         "mag_calibration_window_s", "use_gps")}
    assert PdrSettings.from_dict(old) == PdrSettings()
    with pytest.raises(InputError, match="unknown key"):
        PdrSettings.from_dict({"detectr": "li"})
    with pytest.raises(InputError, match="no such parameter"):
        _run(tmp_path, walk, "--detector", "li", "--detector-param", "nope=1", name="d")


def test_step_length_and_length_param(tmp_path, walk):
    s, _ = _run(tmp_path, walk, "--step-length", "0.61")
    assert s["distance_m"] == pytest.approx(0.61 * s["steps"], rel=1e-9)
    s2, _ = _run(tmp_path, walk, "--length", "ladetto", "--length-param", "a=0.3", "--length-param", "b=0",
                 "--length-param", "c=0", name="l")
    assert s2["distance_m"] == pytest.approx(0.3 * s2["steps"], rel=1e-9)


def test_calibrate_length_and_checkpoints(tmp_path, walk):
    # 20 s at 2 steps/s of 0.7 m = 28 m: the fitted model must give the walk back
    # (exact with an intercept: least-squares residuals sum to zero; weinberg has none)
    for model, key, rel in (("constant", "length_m", 1e-6), ("weinberg", "k", 0.01), ("ladetto", "a", 1e-6)):
        s0, _ = _run(tmp_path, walk, "--length", model, name=model + "0")
        assert abs(s0["distance_m"] / 28.0 - 1) > 0.05
        s, _ = _run(tmp_path, walk, "--length", model, "--calibrate-length", f"{walk}=28",
                    "--save-settings", tmp_path / f"{model}.json", name=model)
        assert key in json.loads((tmp_path / f"{model}.json").read_text())["length_params"]
        assert s["distance_m"] == pytest.approx(28.0, rel=rel)
    with pytest.raises(InputError, match="has no fit"):
        _run(tmp_path, walk, "--length", "renaudin", "--calibrate-length", f"{walk}=28", name="x")
    # checkpoints on the true track (bearing 30 deg, 1.4 m/s from t = 2 s)
    tc = np.array([7.0, 12.0, 21.9])
    d = (tc - 2.0) * 1.4
    np.savetxt(tmp_path / "cp.csv", np.column_stack([tc, d * np.sin(np.radians(30)), d * np.cos(np.radians(30))]),
               delimiter=",", header="t_s,x_m,y_m", comments="")
    s, _ = _run(tmp_path, walk, "--heading", "mag", "--step-length", "0.7", "--checkpoints", tmp_path / "cp.csv",
                name="cp")
    cp = s["checkpoints"]
    assert cp["true_path_m"] == pytest.approx(d[-1], rel=1e-9)
    assert max(cp["error_m"]) < 0.7  # within one step of the truth
    s, _ = _run(tmp_path, walk, "--heading", "none", "--step-length", "0.7", "--checkpoints", tmp_path / "cp.csv",
                name="cp0")  # wrong (north) heading: the last checkpoint is 2 d sin(15 deg) off
    assert s["checkpoints"]["final_error_m"] == pytest.approx(2 * d[-1] * np.sin(np.radians(15)), abs=0.7)


def test_gps_start_and_comparison(tmp_path, walk):
    s, out = _run(tmp_path, walk, "--heading", "mag", "--step-length", "0.7")
    g = s["gps_comparison"]
    assert g["n_fixes"] >= 15 and g["first_fix_t_s"] == 3.0
    assert g["mean_m"] < 0.7 and g["final_m"] < 0.7  # PDR and GPS agree within a step
    ll = np.loadtxt(out / "path_latlon.csv", delimiter=",", skiprows=1)
    assert abs(ll[-1, 1] - g["first_fix"][0]) * 40e6 / 360 > 10  # the path moved away from the first fix ...
    gp = np.loadtxt(out / "gps.csv", delimiter=",", skiprows=1)
    assert np.hypot(*(gp[0, 3:5] - gp[0, 1:3])) == 0.0  # ... having passed it at the fix's time
    s, _ = _run(tmp_path, walk, "--heading", "none", "--step-length", "0.7", name="n")  # heading north: off
    assert s["gps_comparison"]["final_m"] > 5.0
    s, _ = _run(tmp_path, walk, "--no-gps", name="g")
    assert s["gps_comparison"] is None and s["start_lat_lon"] is None


def test_mag_calibration_from_cli(tmp_path):
    # hard iron (30, 10) uT biases the level-device heading by 45 deg; a turn on the spot lets the
    # percentile and ellipse fits remove it
    f = _write_walk(tmp_path / "turn.csv", bearing_deg=0.0, offset=(30.0, 10.0, 0.0), turn_s=6.0, gps=False)
    args = ["--heading", "mag", "--step-length", "0.7"]
    s, out = _run(tmp_path, f, *args, name="raw")
    h = np.loadtxt(out / "steps.csv", delimiter=",", skiprows=1)[:, 3]
    assert np.median(np.abs(np.angle(np.exp(1j * np.radians(h))))) > np.radians(15)
    for method in ("percentile", "ellipse"):
        _, out = _run(tmp_path, f, *args, "--mag-calibration", method, "--mag-calibration-window", "2,8", name=method)
        h = np.loadtxt(out / "steps.csv", delimiter=",", skiprows=1)[:, 3]
        assert np.degrees(np.max(np.abs(np.angle(np.exp(1j * np.radians(h)))))) < 3.0
    with pytest.raises(InputError, match="at least 9"):
        _run(tmp_path, f, *args, "--mag-calibration", "ellipse", "--mag-calibration-window", "0,0.02", name="bad")


def test_calibrate_mag_percentile_literal_offsets_do_not_centre():
    a = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    m = np.column_stack([5 + np.cos(a), -3 + 2 * np.sin(a), np.zeros_like(a)])
    c = calibrate_mag(m, "percentile")
    assert np.allclose(np.percentile(c[:, :2], [5, 95], axis=0).sum(axis=0), 0.0, atol=1e-9)
    lit = calibrate_mag(m, "percentile_literal")
    assert not np.allclose(np.percentile(lit[:, :2], [5, 95], axis=0).sum(axis=0), 0.0, atol=0.1)


def test_untilted_heading_is_eq_3_2_and_tilt_weights_level_a_tilted_phone():
    # eq. 3.2 first row of the thesis' Fig. 4.5: B = (-17.9375, -21.0625) uT -> bearing 139.581 deg
    b = np.array([[-17.9375, -21.0625, -30.0]])
    assert np.degrees(untilted_heading(b))[0] % 360 == pytest.approx(-seed003_theta_deg(b[0, 0], b[0, 1]) % 360,
                                                                      abs=1e-9)
    assert np.degrees(untilted_heading(b))[0] % 360 == pytest.approx(139.581, abs=1e-3)
    # phone pitched 40 deg nose-up, facing bearing 60 deg: the level formula errs, the tilt weights do not
    bearing, pitch = np.radians(60.0), np.radians(40.0)
    r_nb_yaw = np.array([[np.cos(bearing), np.sin(bearing), 0], [-np.sin(bearing), np.cos(bearing), 0], [0, 0, 1]])
    r_pitch = np.array([[1, 0, 0], [0, np.cos(pitch), -np.sin(pitch)], [0, np.sin(pitch), np.cos(pitch)]])
    mat_nb = r_nb_yaw @ r_pitch  # body -> (east, north, up)
    n = 200
    mag_b = np.tile(B_ENU @ mat_nb, (n, 1))
    acc_b = np.tile(np.array([0, 0, G]) @ mat_nb, (n, 1))
    t = np.arange(n) / 20.0
    h_w = np.degrees(tilt_weight_heading(t, mag_b, acc_b))
    assert h_w == pytest.approx(np.full(n, 60.0), abs=1e-6)
    assert abs(np.degrees(untilted_heading(mag_b[:1]))[0] - 60.0) > 10.0


@pytest.mark.parametrize("tilt", ["weights", "none"])
def test_mag_tilt_options_from_cli(tmp_path, walk, tilt):
    _, out = _run(tmp_path, walk, "--heading", "mag", "--mag-tilt", tilt, "--declination", "-5")
    h = np.loadtxt(out / "steps.csv", delimiter=",", skiprows=1)[:, 3]
    assert h == pytest.approx(np.full(h.size, 25.0), abs=0.5)  # level walk at bearing 30, declination 5 W


def test_no_heading_source_is_not_drawn_as_a_path(tmp_path):
    """An accelerometer-only phone file with no compass: steps and distance, but no 'PDR path' (the x/y of the
    steps would be a straight line along the start bearing); the summary and stderr say why."""
    import json
    import subprocess
    import sys

    import numpy as np

    t = np.arange(0, 30, 0.01)
    acc = np.column_stack([0.3 * np.sin(2 * np.pi * 1.8 * t), np.zeros_like(t), 9.81 + 2.5 * np.sin(2 * np.pi * 1.8 * t)])
    csv = tmp_path / "acc.csv"
    np.savetxt(csv, np.column_stack([t, acc]), delimiter=",", header="t_s,ax_mps2,ay_mps2,az_mps2", comments="",
               fmt="%.5f")
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "bootnav.cli", "pdr", str(csv), "--out", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["heading_source"] == "none" and s["is_path"] is False
    assert s["steps"] > 20 and any("not a path" in w for w in s["warnings"])
    assert "not a path" in proc.stderr
    assert not (out / "path.png").exists() and (out / "heading.png").exists()
