"""Floors per stride, storeys from riser counts, and the 1-σ ellipse (``strides``, ``floors``).

Expected values come from geometry: an ellipse built from known axes and orientation, flights of known
risers with a known error added to the climbed height.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bootnav.postproc.floors import storey_offsets
from bootnav.postproc.strides import ELLIPSE_COLUMNS, FloorSettings, ellipse, segment_strides

LEVEL, RMIN, RMAX = 0.075, 0.15, 0.20


@pytest.mark.parametrize("theta", [0.0, 0.4, -1.2, math.pi / 2])
def test_ellipse_of_a_known_covariance(theta):
    a, b = 2.0, 0.5
    rot = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    cov = rot @ np.diag([a * a, b * b]) @ rot.T
    major, minor, orient = ellipse(cov[0, 0], cov[1, 1], cov[0, 1])
    assert major == pytest.approx(a, rel=1e-12) and minor == pytest.approx(b, rel=1e-12)
    # the axis is a line: θ and θ ± π are the same ellipse; the convention returns (−π/2, π/2]
    assert math.sin(2 * (orient - theta)) == pytest.approx(0.0, abs=1e-12)
    assert math.cos(orient - theta) == pytest.approx(1.0 if abs(theta) <= math.pi / 2 else -1.0, abs=1e-12)
    assert -math.pi / 2 < orient <= math.pi / 2


def test_ellipse_of_a_circle_and_of_a_north_south_ellipse():
    major, minor, orient = ellipse(0.09, 0.09, 0.0)
    assert major == minor == pytest.approx(0.3) and orient == 0.0
    major, minor, orient = ellipse(0.01, 0.04, 0.0)  # 0.2 m north-south, 0.1 m east-west
    assert (major, minor) == (pytest.approx(0.2), pytest.approx(0.1)) and orient == pytest.approx(math.pi / 2)


def _walk(z_fp, t_phase=0.5, n_phase=10):
    """Samples of a path standing still in stance phases at the given footprint heights (x advancing 1 m
    per stride), with a swing sample between phases."""
    t, pos, stance = [], [], []
    k = 0
    for i, z in enumerate(z_fp):
        for _ in range(n_phase):
            t.append(k * 0.05)
            pos.append((float(i), 0.0, z))
            stance.append(True)
            k += 1
        t.append(k * 0.05)
        pos.append((i + 0.5, 0.0, z + 0.1))
        stance.append(False)
        k += 1
    return np.array(t), np.array(pos), np.array(stance)


def test_strides_carry_their_floor_and_the_ellipse_of_the_stance_phase_end():
    z = [0.0, 0.0, 1.7, 3.4, 3.4, 6.8, 3.4]  # floors 0, 0, 0 (1.7 < 2.0), 1, 1, 2, 1 with 3 m and 0.5 m
    t, pos, stance = _walk(z)
    sig = np.tile([0.3, 0.2, 0.1], (len(t), 1))
    cen = np.zeros(len(t))
    ends = np.flatnonzero(stance[:-1] & ~stance[1:])
    sig[ends, 0], cen[ends] = 0.5, 0.06  # the covariance at the last sample of each stance phase counts
    steps = segment_strides(t, pos, stance, floors=FloorSettings(3.0, 0.5), pos_sigma_n=sig, pos_cov_en=cen)
    assert steps["floor"].tolist() == [0, 0, 1, 1, 2, 1]
    major, minor, orient = ellipse(0.25, 0.04, 0.06)
    for c, v in zip(ELLIPSE_COLUMNS, (major, minor, orient)):
        assert np.allclose(steps[c], v, rtol=1e-12)
    assert "ellipse_major_m" not in segment_strides(t, pos, stance)  # no covariance given: no ellipse


def _flights(risers, riser_m, errors, level_strides=3):
    """Footprint heights: level strides, then flights of 2 risers a stride (``risers`` > 0 up, < 0 down,
    each with its climbed-height error added on its last stride), level strides between."""
    z, h = [0.0] * level_strides, 0.0
    for n, err in zip(risers, errors):
        sgn = 1 if n > 0 else -1
        for i in range(abs(n) // 2):
            h += sgn * 2 * riser_m + (err if i == abs(n) // 2 - 1 else 0.0)
            z.append(h)
        z += [h] * level_strides
    return np.array(z)


def test_up_and_down_the_same_flights_lands_on_the_start_despite_a_height_error():
    """18 risers of 0.17 m up (measured 6 cm too high), the same down (4 cm too low): the start's level
    again, exactly, while the filter's heights end 2 cm off; the flights agree and the landing down is on a
    level visited before."""
    z = _flights([18, -18], 0.17, [0.06, -0.04])
    res = storey_offsets(z, LEVEL, RMIN, RMAX)
    corrected = z + res.offset_fp
    assert res.flights == res.agreeing == 2 and res.snapped == 1 and res.risers == 36
    assert corrected[-1] == pytest.approx(0.0, abs=1e-12) and z[-1] == pytest.approx(0.02)
    top = corrected[3 + 9: 3 + 9 + 3]
    assert np.allclose(top, 18 * 0.17 + 0.06)  # the first flight sets the riser estimate: its landing stays
    assert res.riser_m == pytest.approx((3.12 + 3.10) / 36)  # pooled over both flights
    assert np.all(np.diff(corrected[2:2 + 10]) > 0.3)  # the climb (9 strides of 2 risers) is not flattened
    # the floor count's height: what the agreeing flights climbed (here the corrected heights themselves)
    assert np.allclose(res.climbed_fp, corrected - corrected[0], atol=1e-12)


def test_a_flight_whose_risers_and_height_disagree_is_left_as_the_filter_says():
    """A 'flight' of two strides of 0.6 m each: 3-4 risers a stride counted as 3 → 6 risers; 1.2 m is
    within 6 × [0.15, 0.20] ± 0.075, so make the strides 0.26 m: each counts 1 riser (0.26/0.175 → 1), and
    0.52 m > 2 × 0.20 + 0.075: they disagree, nothing is changed."""
    z = np.array([0.0, 0.0, 0.26, 0.52, 0.52, 0.52])
    res = storey_offsets(z, LEVEL, RMIN, RMAX)
    assert res.flights == 1 and res.agreeing == 0 and not np.any(res.offset_fp)
    assert not np.any(res.climbed_fp)  # nor is it counted as a climb (running drift, a ramp, a bad stride)


def test_level_walks_are_flat_and_single_steps_are_not_flights():
    """Drift on a floor (each stride below the gate) is flattened to the floor's height; a lone stride of less
    than one riser (kneeling down −0.12 m, standing up, the first stride after a long stand) is the sensor, not
    the building: put back on the floor; a lone stride of a riser or more (a kerb, 0.17 m) moves the plateau.
    Neither counts as a flight."""
    z = np.array([0.0, 0.01, -0.02, 0.0, -0.12, -0.13, -0.01, 0.02])
    res = storey_offsets(z, LEVEL, RMIN, RMAX)
    assert res.flights == 0 and res.lone_held == 2
    assert np.allclose(z + res.offset_fp, 0.0, atol=1e-12)
    kerb = np.array([0.0, 0.01, 0.18, 0.19, 0.17])
    res = storey_offsets(kerb, LEVEL, RMIN, RMAX)
    assert res.flights == 0 and res.lone_held == 0
    assert np.allclose(kerb + res.offset_fp, [0.0, 0.0, 0.17, 0.17, 0.17], atol=1e-12)  # its own 0.17 m change


def test_a_toe_first_landing_is_a_roll_not_a_stride():
    """Stairs down (risers of 0.1975 m) landing toe-first: each stair stride (−0.36 m, 0.3 m forward) ends on
    the toe, 3.5 cm above the flat foot, then the heel drops in place (−0.035 m, 2 cm forward). The roll footprints take
    their flat footprint's correction; the flight is one flight of 2 risers a stride, not 1-stride steps."""
    fp = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)]
    x, z = 1.0, 0.0
    for _ in range(5):
        x, z = x + 0.3, z - 0.36
        fp.append((x, 0.0, z))
        x, z = x + 0.02, z - 0.035
        fp.append((x, 0.0, z))
    fp += [(x + 1.0, 0.0, z), (x + 2.0, 0.0, z)]
    fp = np.array(fp)
    res = storey_offsets(fp, LEVEL, RMIN, RMAX, min_stride_m=0.10)
    assert res.flights == res.agreeing == 1 and res.risers == 10
    corrected = fp[:, 2] + res.offset_fp
    assert np.allclose(corrected[-3:], z)  # the flight is kept (its own riser estimate), the floor flat
    assert np.allclose(corrected[3::2][:5] - corrected[2::2][:5], -0.035)  # a roll keeps its own height change
    flat = storey_offsets(fp, LEVEL, RMIN, RMAX, min_stride_m=0.0)  # without the roll rule: 1-stride steps
    assert flat.flights == 0


def test_storey_numbers_count_the_storeys_walked_not_a_nominal_height():
    """3.5 m storeys, 8 level strides walked on each of floors 0-4 between stair flights: the numbers are
    0-4 (a nominal 3 m would make the 4th floor, 14 m up, floor 5); a stairwell climbed straight through
    floors 1-2 (no level walk there) still counts them, from the spacing of the storeys walked."""
    from bootnav.postproc.floors import storey_numbers

    z, true = [], []
    for floor in range(5):
        z += [floor * 3.5] * 9
        true += [floor] * 9
        if floor < 4:
            z += list(floor * 3.5 + np.arange(1, 10) * 0.35)  # 10 risers of 0.175 m, two a stride
            true += [floor + (k >= 5) for k in range(9)]  # nearest storey: the lower half of the flight below
    number, found = storey_numbers(np.array(z), LEVEL, 0.5, storey_m=3.0)
    half = np.isclose(np.mod(np.array(z), 3.5), 1.75)  # a stride exactly half-way: either storey is right
    assert np.array_equal(number[~half], np.array(true)[~half]) and half.sum() == 4
    assert len(found) == 5
    straight = np.concatenate(([0.0] * 9, np.arange(1, 30) * 0.35, [10.5] * 9, np.arange(1, 10) * 0.35 + 10.5,
                               [14.0] * 9))
    number, _ = storey_numbers(straight, LEVEL, 0.5, storey_m=3.0)
    assert number[0] == 0 and number[-1] == 4 and set(number[9:38].tolist()) == {0, 1, 2, 3}
