"""`bootnav pdr` settings: checked like `process`'s (unknown keys, wrong types, negative durations, named by
their key path), every heading parameter wired through the CLI, outputs never overwritten without --force,
and a clock restart refused instead of interleaving the two halves' steps (issue 14).

Synthetic level phone (+y forward) as Physics Toolbox CSVs: 2 steps/s, known bearing profile, field and
gyro consistent with it."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

from bootnav.cli import main
from bootnav.errors import InputError
from bootnav.postproc.pdr import PdrSettings, cli

G = 9.80665
B_ENU = np.array([0.0, 20.0, -40.0])  # uT: 20 north, 40 down
FS = 100.0


def _walk(path, bearing_deg, gyro_extra=None, mag_extra=None):
    """Walk whose bearing follows ``bearing_deg(t)`` (deg, clockwise from north), steps at 2 Hz from t = 2 s.
    Gyro: w_z = -d(bearing)/dt (a right turn is clockwise seen from above); ``gyro_extra(t)`` / ``mag_extra(t)``
    add (N, 3) terms."""
    t = np.arange(0.0, 24.0, 1.0 / FS)
    walking = t >= 2.0
    az = G + np.where(walking, 2.5 * np.sin(2 * np.pi * 2.0 * (t - 2.0)), 0.0)
    psi = np.radians(bearing_deg(t))
    wz = -np.gradient(psi, t)
    gyro = np.column_stack([np.zeros_like(t), np.zeros_like(t), wz])
    if gyro_extra is not None:
        gyro = gyro + gyro_extra(t)
    mag = np.column_stack([B_ENU[0] * np.cos(psi) - B_ENU[1] * np.sin(psi),
                           B_ENU[0] * np.sin(psi) + B_ENU[1] * np.cos(psi), np.full_like(t, B_ENU[2])])
    if mag_extra is not None:
        mag = mag + mag_extra(t)
    rows = ["time,gFx,gFy,gFz,wx,wy,wz,Bx,By,Bz"]
    rows += [f"{t[i]:.3f},0,0,{az[i] / G:.6f},{gyro[i, 0]:.6f},{gyro[i, 1]:.6f},{gyro[i, 2]:.6f},"
             f"{mag[i, 0]:.4f},{mag[i, 1]:.4f},{mag[i, 2]:.4f}" for i in range(t.size)]
    path.write_text("\n".join(rows) + "\n")
    return path


def _turn(t):
    """North for 10 s of walking, a 90-deg right turn in 2 s, then east."""
    return np.clip((t - 12.0) / 2.0, 0.0, 1.0) * 90.0


def _run(tmp_path, *argv, name="o"):
    p = argparse.ArgumentParser()
    cli.add_arguments(p)
    out = tmp_path / name
    assert cli.run(p.parse_args([*map(str, argv), "--no-plots", "--out", str(out)])) == 0
    s = json.loads((out / "summary.json").read_text())
    return s, np.loadtxt(out / "steps.csv", delimiter=",", skiprows=1, ndmin=2)


def _bearing(steps):
    """Bearing of each step, deg in (-180, 180]."""
    return np.mod(steps[:, 3] + 180.0, 360.0) - 180.0


@pytest.fixture(scope="module")
def turn_walk(tmp_path_factory):
    return _walk(tmp_path_factory.mktemp("t") / "turn.csv", _turn)


# ------------------------------------------------------------------------------------------- validation
@pytest.mark.parametrize("data,needle", [
    ({"detector": "li", "detector_params": {"nope": 1}}, "settings.detector_params: unknown key(s) ['nope']"),
    ({"detector": "li", "detector_params": {"max_step_s": -1.0}}, "settings.detector_params.max_step_s: a duration"),
    ({"detector": "li", "detector_params": {"min_peak_mps2": True}}, "settings.detector_params.min_peak_mps2: "
                                                                      "expected a finite number, got true"),
    ({"length": "weinberg", "length_params": {"k": "big"}}, "settings.length_params.k: expected a finite number"),
    ({"length": "weinberg", "length_params": {"kk": 1}}, "settings.length_params: unknown key(s) ['kk']"),
    ({"detector_params": [1]}, "settings.detector_params: expected an object"),
    ({"complementary_tau_s": -3}, "settings.complementary_tau_s: a duration cannot be negative"),
    ({"compass_window_s": -0.4}, "settings.compass_window_s: a duration cannot be negative"),
    ({"heading0_deg": True}, "settings.heading0_deg: expected a finite number, got true"),
    ({"use_gps": 1}, "settings.use_gps: expected true or false"),
    ({"heading": "magnetic"}, "settings.heading: unknown heading 'magnetic'"),
    ({"mag_tilt": "level"}, "settings.mag_tilt: unknown"),
    ({"mag_calibration": "sphere"}, "settings.mag_calibration: unknown"),
    ({"detector": "lee"}, "settings.detector: unknown detector 'lee'"),
    ({"forward_axis": [0, 1]}, "settings.forward_axis: expected 3 finite numbers"),
    ({"forward_axis": [0, 0, 0]}, "settings.forward_axis: the zero vector"),
    ({"mag_percentiles": [95, 5]}, "settings.mag_percentiles: expected 0 <= low < high <= 100"),
    ({"mag_calibration_window_s": [8, 2]}, "settings.mag_calibration_window_s: expected 0 <= t0 < t1"),
    ({"start_lat_lon": [91, 0]}, "settings.start_lat_lon: latitude must be in [-90, 90]"),
    ({"gravity_cutoff_hz": 0}, "settings.gravity_cutoff_hz: must be positive"),
    ({"heading_deg": 3}, "settings: unknown key(s) ['heading_deg']"),
])
def test_bad_settings_are_named_by_key_path(data, needle):
    with pytest.raises(InputError) as exc:
        PdrSettings.from_dict(data)
    assert needle in str(exc.value)


def test_settings_roundtrip_and_validate_of_an_object():
    s = PdrSettings(detector="li", detector_params={"max_step_s": 1.2}, length="weinberg", length_params={"k": 0.55},
                    mag_percentiles=(2.0, 98.0), mag_calibration_window_s=(1.0, 9.0), start_lat_lon=(46.5, 32.6))
    assert PdrSettings.from_dict(json.loads(json.dumps(s.to_dict()))) == s
    with pytest.raises(InputError, match=r"settings\.detector_params\.max_step_s"):
        PdrSettings(detector="li", detector_params={"max_step_s": -1.0}).validate()


def test_settings_file_errors_through_the_command(tmp_path, capsys, turn_walk):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"detector": "footpath", "detector_params": {"lockout_samples": 2.5}}))
    code = main(["pdr", str(turn_walk), "--settings", str(bad), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code != 0 and "Traceback" not in "\n".join(err)
    assert err[-1].startswith("bootnav pdr: error: ") and str(bad) in err[-1]
    assert "settings.detector_params.lockout_samples: expected an integer, got 2.5" in err[-1]
    assert not (tmp_path / "o").exists()  # refused before any work
    code = main(["pdr", str(turn_walk), "--set", "compass_window_s=-1", "--out", str(tmp_path / "o")])
    assert code != 0 and "settings.compass_window_s: a duration cannot be negative" in capsys.readouterr().err


# ------------------------------------------------------------------------------------------- heading
def test_gyro_and_complementary_heading_from_the_command(tmp_path, turn_walk):
    for method in ("gyro", "complementary", "mag"):
        s, steps = _run(tmp_path, turn_walk, "--heading", method, "--step-length", "0.7", name=method)
        assert s["heading_source"] == method and s["settings"]["heading"] == method
        b = _bearing(steps)
        first, last = b[(steps[:, 0] > 3) & (steps[:, 0] < 11)], b[steps[:, 0] > 15]
        assert np.abs(first).max() < 2.0 and np.abs(last - 90.0).max() < 2.0, (method, b)
        # the path: the true bearing at each detected step, 0.7 m a step
        true_b = np.radians(_turn(steps[:, 0]))
        assert s["final_x_m"] == pytest.approx(0.7 * np.sin(true_b).sum(), abs=0.7)
        assert s["final_y_m"] == pytest.approx(0.7 * np.cos(true_b).sum(), abs=0.7)
    s, steps = _run(tmp_path, turn_walk, "--heading", "gyro", "--heading0", "-90", name="h0")
    assert np.abs(_bearing(steps)[steps[:, 0] > 15]).max() < 2.0  # started west, turned right: north


def test_gyro_signed_magnitude_from_the_command(tmp_path):
    # during the turn the phone also rolls at the same rate as it turns: |w| = sqrt(2) |w_v|, so eqs. 2.7-2.8
    # turn sqrt(2) * 90 = 127.3 deg where the vertical rate turns 90
    f = _walk(tmp_path / "roll.csv", _turn,
              gyro_extra=lambda t: np.column_stack([np.where((t >= 12) & (t <= 14), np.pi / 4, 0.0),
                                                    np.zeros_like(t), np.zeros_like(t)]))
    _, steps = _run(tmp_path, f, "--heading", "gyro", name="v")
    _, steps_sm = _run(tmp_path, f, "--heading", "gyro", "--gyro-signed-magnitude", name="sm")
    late = steps[:, 0] > 15
    assert np.abs(_bearing(steps)[late] - 90.0).max() < 2.0
    assert np.abs(_bearing(steps_sm)[late] - 90.0 * np.sqrt(2)).max() < 2.0


def test_mag_percentiles_from_the_command(tmp_path):
    # a turn on the spot with hard iron (30, 10) uT and five 200-uT spikes on x: the 5/95 percentiles ignore
    # the spikes, 0/100 take them as the field's range and leave the heading tens of degrees off
    def spin(t):
        return np.clip((t - 0.2) / 1.6, 0.0, 1.0) * 360.0

    spikes = np.zeros(2400, bool)
    spikes[[30, 60, 90, 120, 150]] = True
    f = _walk(tmp_path / "spin.csv", spin,
              mag_extra=lambda t: np.column_stack([30.0 + 200.0 * spikes[:t.size], np.full_like(t, 10.0),
                                                   np.zeros_like(t)]))
    args = ["--heading", "mag", "--mag-calibration", "percentile", "--mag-calibration-window", "0,2"]
    _, steps = _run(tmp_path, f, *args, name="p5")
    s, steps_full = _run(tmp_path, f, *args, "--mag-percentiles", "0,100", name="p0")
    assert s["settings"]["mag_percentiles"] == [0.0, 100.0]
    assert np.abs(_bearing(steps)).max() < 3.0
    assert np.median(np.abs(_bearing(steps_full))) > 20.0


def test_compass_window_from_the_command(tmp_path):
    # 20 Hz waist log ([NKUA2009]) whose compass alternates 30 / 50 deg sample by sample: the 0.4-s circular
    # mean gives 40, a window shorter than one sample gives 30 or 50
    t = np.arange(0.0, 20.0, 0.05)
    az_g = 1.0 + 0.25 * np.sin(2 * np.pi * 2.0 * t) * (t >= 2)
    compass = np.where(np.arange(t.size) % 2 == 0, 30.0, 50.0)
    rows = ["time_ms\tacc_x_g\tacc_y_g\tacc_z_g\theading_deg"]
    rows += [f"{1000 * t[i]:.0f}\t0\t0\t{az_g[i]:.5f}\t{compass[i]:.1f}" for i in range(t.size)]
    f = tmp_path / "waist.txt"
    f.write_text("\n".join(rows) + "\n")
    s, steps = _run(tmp_path, f, "--heading", "compass", "--detector", "robust", name="w")
    assert s["heading_source"] == "compass" and s["steps"] > 20
    assert np.abs(_bearing(steps) - 40.0).max() < 0.5
    s, steps = _run(tmp_path, f, "--heading", "compass", "--set", "compass_window_s=0.01", name="w1")
    assert s["settings"]["compass_window_s"] == 0.01
    assert np.all(np.minimum(np.abs(_bearing(steps) - 30.0), np.abs(_bearing(steps) - 50.0)) < 1e-6)


# ------------------------------------------------------------------------------------------- outputs
def test_outputs_are_not_overwritten_without_force(tmp_path, capsys, turn_walk):
    out = tmp_path / "o"
    argv = ["pdr", str(turn_walk), "--no-plots", "--out", str(out)]
    assert main(argv) == 0
    before = (out / "summary.json").read_bytes()
    assert main([*argv, "--step-length", "0.5"]) != 0
    assert "steps.csv exists; use --force" in capsys.readouterr().err
    assert (out / "summary.json").read_bytes() == before
    assert main([*argv, "--step-length", "0.5", "--force"]) == 0
    assert json.loads((out / "summary.json").read_text())["settings"]["length_params"] == {"length_m": 0.5}
    assert not list(out.glob(".*tmp*"))  # no temporary file left behind
    assert main(["pdr", str(turn_walk), "--out", str(tmp_path / "p"), "--save-settings", str(turn_walk)]) != 0
    assert "is an input" in capsys.readouterr().err


# ------------------------------------------------------------------------------------------- time restart
def test_clock_restart_is_refused_not_interleaved(tmp_path, capsys):
    """Issue 14: two 8-step walks whose clock restarts at 0 in between. Sorting interleaved them into 21
    steps; like `process`, pdr now refuses time going backwards, naming the sample, and each part on its own
    counts its 8 steps."""
    t1 = np.arange(0.0, 7.0, 0.01)
    az = G + np.where((t1 >= 2.0) & (t1 < 6.0), 2.5 * np.sin(2 * np.pi * 2.0 * (t1 - 2.0)), 0.0)
    part = np.column_stack([t1, np.zeros_like(t1), np.zeros_like(t1), az])
    header = "t_s,ax_mps2,ay_mps2,az_mps2"
    whole = tmp_path / "restart.csv"
    np.savetxt(whole, np.vstack([part, part]), delimiter=",", header=header, comments="", fmt="%.5f")
    code = main(["pdr", str(whole), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code != 0 and err[-1].startswith("bootnav pdr: error: ") and "Traceback" not in "\n".join(err)
    assert f"{whole}: sample {t1.size}: time goes backwards (6.990000 s -> 0.000000 s" in err[-1]
    one = tmp_path / "part.csv"
    np.savetxt(one, part, delimiter=",", header=header, comments="", fmt="%.5f")
    s, _ = _run(tmp_path, one, name="part")
    assert s["steps"] == 8


def test_gps_track_is_plotted_with_the_pdr_path(tmp_path, capsys):
    """[Lazarevskiy2021, Fig. 3.13]: with GPS columns the output has gps.csv and path_gps.png, and the message
    gives the mean / final distance to the GPS track."""
    from tests.test_pdr_cli_settings import _write_walk

    f = _write_walk(tmp_path / "gps.csv", bearing_deg=30.0)
    out = tmp_path / "o"
    assert main(["pdr", str(f), "--heading", "mag", "--step-length", "0.7", "--out", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert "path_gps.png" in s["plots"] and (out / "path_gps.png").stat().st_size > 10_000
    g = np.loadtxt(out / "gps.csv", delimiter=",", skiprows=1)
    assert g.shape[0] == s["gps_comparison"]["n_fixes"]
    stdout = capsys.readouterr().out
    assert f"{s['gps_comparison']['mean_m']:.1f} m mean / {s['gps_comparison']['final_m']:.1f} m final from GPS" in stdout
