"""Stairs are not flattened by the height hold and the storeys, and the floor column is right (simulator truth).

Tolerances from physics: with the ideal sensor, the climb within one riser (0.15 m: less would be a riser
lost or invented); with the datasheet MPU6050 (uncalibrated: accelerometer scale σ 1 %, cross-axis 0.7 %,
``docs/simulator.md``), within 5 % of the climb (3σ of the scale plus the cross-axis coupling). Flattened
stairs would lose the whole climb.
"""

from __future__ import annotations

import numpy as np
import pytest

from bootnav.postproc.pipeline import process
from bootnav.postproc.settings import ProcessSettings
from bootnav.postproc.strides import footprints, stride_footprints
from bootnav.simulator import simulate, write_h5

PROFILES = ["ideal", "mpu6050-16g-2000dps"]


def _run(tmp_path, scenario, profile, **settings):
    res = simulate(scenario, seed=0, profile=profile, rate_hz=100.0)
    path = tmp_path / f"{scenario}-{profile}.h5"
    write_h5(res, path)
    s = ProcessSettings()
    for k, v in settings.items():
        setattr(s, k, v)
    return process(path, s), np.asarray(res.truth["pos_n_m"], float)


def _tolerance(profile, climb_m):
    return 0.15 if profile == "ideal" else 0.05 * abs(climb_m)


@pytest.mark.parametrize("profile", PROFILES)
def test_paper_stairs_climb_is_kept(tmp_path, profile):
    r, truth = _run(tmp_path, "paper-stairs", profile)
    climb = truth[-1, 2] - truth[0, 2]
    assert climb == pytest.approx(1.70, abs=0.01)
    assert r.nav.info["level_height_updates"] >= 5  # the hold acted on the 3 m + 5 m of level walk (1.4 m strides)
    est = r.pos_n[-1, 2] - r.pos_n[0, 2]
    assert abs(est - climb) < _tolerance(profile, climb)


@pytest.mark.parametrize("profile", PROFILES)
def test_three_floors_climb_and_floor_column(tmp_path, profile):
    r, truth = _run(tmp_path, "three-floors", profile)
    climb = truth[-1, 2] - truth[0, 2]
    assert climb == pytest.approx(9.0, abs=0.05)
    est = r.pos_n[-1, 2] - r.pos_n[0, 2]
    assert abs(est - climb) < _tolerance(profile, climb)
    storeys = r.summary["path"]["storeys"]
    assert storeys["flights"] >= 6  # 3 storeys × 2 flights of 9 risers (U-shaped, half landings)
    # the floor column: the storey nearest the true footprint height (3 m storeys) of every stride, except
    # where the truth itself is ambiguous: within 0.3 m (two risers) of half a storey (the half landings)
    steps = r.steps
    _, fp = footprints(r.t_s, r.pos_n, r.stance)
    _, fp_true = footprints(r.t_s, truth, r.stance)
    keep = stride_footprints(fp, r.settings.selftune.min_stride_m)
    storeys_true = (fp_true[keep, 2] - fp_true[0, 2])[1:] / 3.0
    clear = np.abs(np.mod(storeys_true, 1.0) - 0.5) > 0.1
    assert steps["floor"][-1] == 3 and steps["floor"][0] == 0
    assert np.mean(steps["floor"][clear] == np.rint(storeys_true[clear])) > 0.95  # a stride or two may differ


def test_the_hold_and_the_storeys_can_be_turned_off(tmp_path):
    r, _ = _run(tmp_path, "paper-stairs", "ideal", floor_storeys=False)
    assert r.summary["path"]["storeys"] is None
    s = ProcessSettings()
    s.filter.level_height = False
    r2 = process(tmp_path / "paper-stairs-ideal.h5", s)
    assert r2.nav.info["level_height_updates"] == 0 and not r2.nav.info["level_height"]
