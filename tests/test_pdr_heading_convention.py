"""One heading convention in every output (bootnav.CONVENTIONS["heading"]): the steps.csv of the foot-mounted
pipeline and of ``bootnav pdr`` name and sign a direction of travel the same way — a walk due north, then
due east, gives yaw_enu_rad = pi/2 then 0 and heading_deg_cw_from_north = 0 then 90 in both files."""

import csv
import gzip
import subprocess
import sys

import numpy as np
import pytest

from bootnav import CONVENTIONS
from bootnav.postproc.outputs import heading_columns, write_steps_csv
from bootnav.postproc.strides import segment_strides
from tests.conftest import REPO
from tests.test_pdr_detectors import walk

NORTH = {"yaw_enu_rad": np.pi / 2, "heading_deg_cw_from_north": 0.0}
EAST = {"yaw_enu_rad": 0.0, "heading_deg_cw_from_north": 90.0}


def _columns(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def _foot_steps(tmp_path):
    """Footprints 1.4 m apart: 4 strides due north, then 4 due east; 0.3-s stance, 0.7-s swing at 100 Hz."""
    fp = np.array([[0, 1.4 * k, 0] for k in range(5)] + [[1.4 * k, 5.6, 0] for k in range(1, 5)], float)
    pos, stance = [], []
    for k, p in enumerate(fp):
        pos += [p] * 30
        stance += [True] * 30
        if k + 1 < len(fp):
            pos += list(p + np.linspace(0, 1, 70)[:, None] * (fp[k + 1] - p))
            stance += [False] * 70
    t = np.arange(len(pos)) / 100.0
    path = write_steps_csv(tmp_path / "foot_steps.csv", segment_strides(t, np.array(pos), np.array(stance)))
    cols = _columns(path)
    return {key: v[:4] for key, v in cols.items()}, {key: v[4:] for key, v in cols.items()}


def _pdr_steps(tmp_path):
    """``bootnav pdr`` on a synthetic walk whose gyro turns it 90 deg to the right (clockwise seen from above,
    negative rate about up) between t = 18 s and 19 s; start bearing 0 = north."""
    t, acc = walk(n_steps=60)
    gyro = np.zeros_like(acc)
    gyro[(t >= 18.0) & (t < 19.0), 2] = -np.pi / 2
    src = tmp_path / "imu.csv.gz"
    with gzip.open(src, "wt") as f:
        f.write("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\n")
        np.savetxt(f, np.c_[t, acc, gyro], delimiter=",", fmt="%.6f")
    out = tmp_path / "pdr"
    proc = subprocess.run([sys.executable, "-m", "bootnav.cli", "pdr", str(src), "--heading", "gyro", "--no-plots",
                           "--out", str(out)], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert proc.returncode == 0, proc.stderr
    cols = _columns(out / "steps.csv")
    before, after = cols["t_s"] < 17.5, cols["t_s"] > 19.5
    assert before.sum() > 10 and after.sum() > 10
    return {k: v[before] for k, v in cols.items()}, {k: v[after] for k, v in cols.items()}


def _assert_direction(cols, want, tol_deg, label):
    yaw_err = np.angle(np.exp(1j * (cols["yaw_enu_rad"] - want["yaw_enu_rad"])))
    assert np.all(np.abs(np.degrees(yaw_err)) < tol_deg), (label, cols["yaw_enu_rad"])
    compass_err = np.mod(cols["heading_deg_cw_from_north"] - want["heading_deg_cw_from_north"] + 180.0, 360.0) - 180.0
    assert np.all(np.abs(compass_err) < tol_deg), (label, cols["heading_deg_cw_from_north"])


def test_foot_and_pdr_steps_agree_north_then_east(tmp_path):
    foot_north, foot_east = _foot_steps(tmp_path)
    pdr_north, pdr_east = _pdr_steps(tmp_path)
    assert set(NORTH) <= set(foot_north) and set(NORTH) <= set(pdr_north)
    assert "heading_rad" not in foot_north and "heading_rad" not in pdr_north
    # the foot path is exact (CSV rounding only); the PDR gyro heading carries the ~0.01-rad tilt error of
    # the gravity estimate under the synthetic walk's 1 m/s^2 sway (test_pdr_heading_path): 2 deg
    _assert_direction(foot_north, NORTH, 1e-3, "foot north")
    _assert_direction(foot_east, EAST, 1e-3, "foot east")
    _assert_direction(pdr_north, NORTH, 2.0, "pdr north")
    _assert_direction(pdr_east, EAST, 2.0, "pdr east")
    # and the positions move the way the columns say: north raises y, east raises x
    assert np.all(np.diff(pdr_north["y_m"]) > 0) and np.all(np.diff(pdr_east["x_m"]) > 0)
    assert np.all(np.diff(foot_east["x_m"]) > 0)


@pytest.mark.parametrize("yaw,compass", [(np.pi / 2, 0.0), (0.0, 90.0), (-np.pi / 2, 180.0), (np.pi, 270.0),
                                         (np.radians(45.0), 45.0), (np.nextafter(np.pi / 2, 4.0), 0.0)])
def test_heading_columns_formula(yaw, compass):
    # the last case is 1 ulp left of north: (90 - 90.00000000000001) mod 360 rounds to 360.0, written as 0
    got = heading_columns([yaw])["heading_deg_cw_from_north"][0]
    assert 0.0 <= got < 360.0 and got == pytest.approx(compass, abs=1e-9)


def test_convention_is_written_with_every_output():
    assert "yaw_enu_rad" in CONVENTIONS["heading"] and "heading_deg_cw_from_north" in CONVENTIONS["heading"]
