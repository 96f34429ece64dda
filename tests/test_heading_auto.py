"""The truth-free decision of ``heading_aid = "auto"`` (postproc.building.directions) and its causal form."""

import math
from dataclasses import replace

import numpy as np
import pytest

from bootnav.postproc.building.directions import CausalDirections, decide, grid_error
from bootnav.postproc.ins.settings import FilterSettings

S = FilterSettings(heading_aid="auto")


def _path(legs, rng, stride=1.3, sigma_deg=2.0):
    """Footprints of legs (heading_rad, n_strides), each stride's heading scattered by sigma_deg."""
    pts = [np.zeros(2)]
    for heading, n in legs:
        for _ in range(n):
            h = heading + math.radians(sigma_deg) * rng.standard_normal()
            pts.append(pts[-1] + stride * np.array([math.cos(h), math.sin(h)]))
    return np.array(pts)


def test_grid_error_is_periodic():
    for theta in (0.0, 0.3, -1.2):
        for m in range(-4, 5):
            assert abs(grid_error(theta + m * math.pi / 2 + 0.05, theta) - 0.05) < 1e-12


def test_rectilinear_walk_turns_it_on_at_its_grid():
    rng = np.random.default_rng(1)
    axis = 0.4
    legs = [(axis + k * math.pi / 2, int(rng.integers(6, 25))) for k in rng.integers(0, 4, 40)]
    d = decide(_path(legs, rng), S)
    assert d.on, d.reason
    assert abs(grid_error(d.reference_rad, axis)) < math.radians(3.0)
    assert d.share > 0.8 and d.windows


def test_free_walk_and_out_and_back_stay_off():
    rng = np.random.default_rng(2)
    free = [(float(rng.uniform(-math.pi, math.pi)), int(rng.integers(4, 15))) for _ in range(60)]
    d = decide(_path(free, rng), S)
    assert not d.on and d.share < S.hde_auto_min_share, d.reason
    # out and back along one line: all on a grid, but nothing at right angles (turns are not straight strides)
    back = [(0.7 + (k % 2) * math.pi, 16) for k in range(20)]
    d = decide(_path(back, rng), S)
    assert not d.on and d.share > 0.8 and d.cross < S.hde_auto_min_cross, d.reason


def test_too_few_strides_is_off_with_a_reason():
    d = decide(np.zeros((3, 2)), S)
    assert not d.on and "too few" in d.reason


def test_causal_rule_switches_on_once_and_matches_the_batch_rule():
    rng = np.random.default_rng(3)
    legs = [(k * math.pi / 2, 12) for k in rng.integers(0, 4, 30)]
    fp = _path(legs, rng)
    c = CausalDirections(S)
    switched = [c.push(fp[i:i + 7]) for i in range(0, len(fp), 7)]  # any chunking
    assert sum(switched) == 1 and c.on
    assert abs(grid_error(c.reference_rad, 0.0)) < math.radians(3.0)
    # it decides once it has seen the fewest straight strides it may decide on, not before
    assert c.decided_at_stride >= S.hde_auto_min_strides + 2  # a straight stride needs both neighbours
    assert decide(fp, S).on


@pytest.mark.parametrize("bad", [dict(heading_aid="sometimes"), dict(hde_auto_window=2),
                                 dict(hde_auto_min_share=1.5), dict(heading_aid_reference_rad=float("nan"))])
def test_settings_are_checked(bad):
    with pytest.raises(ValueError):
        replace(S, **bad).validate()
