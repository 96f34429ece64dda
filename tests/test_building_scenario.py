"""The ``building`` scenario: plan geometry, stairs, the way out, determinism and duration."""

import json
import math

import numpy as np
import pytest

from bootnav.simulator import simulate
from bootnav.simulator.building import BUILDING
from bootnav.simulator.gait import GAIT_CODES
from bootnav.simulator.scenarios import SCENARIOS


def _make(seed, duration=None):
    return SCENARIOS["building"].make(np.random.default_rng(seed), duration)


@pytest.fixture(scope="module")
def walks():
    return {seed: _make(seed) for seed in (11, 12)}


def _ends(pb):
    st = pb.step_table()
    return st, pb.build().evaluate(st["t_end_s"])[0][:, :3]


@pytest.mark.parametrize("seed", [11, 12])
def test_plan_ranges_and_path_stays_in_the_plan(walks, seed):
    pb = walks[seed]
    plan, g = pb.plan, BUILDING
    assert g["storeys"][0] <= plan.storeys <= g["storeys"][1]
    assert g["storey_height_m"][0] <= plan.storey_height_m <= g["storey_height_m"][1]
    assert g["riser_m"][0] - 1e-12 <= plan.riser_m <= g["riser_m"][1] + 1e-12
    st, ends = _ends(pb)
    bx, by = plan.to_building(ends[:, 0], ends[:, 1])
    # every foot rest lies in a walkable region (corridor, room, stairwell, wing, arc, hall; 0.3 m: the foot
    # origin is not the walker's centre)
    assert plan.inside(bx, by).all()


@pytest.mark.parametrize("seed", [11, 12])
def test_stairs_climb_whole_storeys(walks, seed):
    pb = walks[seed]
    plan = pb.plan
    st, ends = _ends(pb)
    on_toe = np.isin(st["kind"], [GAIT_CODES[k] for k in ("crawl", "kneel", "stand_up")])  # foot origin raised
    level = (np.abs(st["dz_m"]) < 1e-12) & ~on_toe
    z = ends[level, 2] / plan.storey_height_m
    # on the level the foot is exactly on a storey or on the U stairwell's half landing (n/2 risers of h / n)
    np.testing.assert_allclose(2 * z, np.rint(2 * z), atol=1e-9)
    half = np.abs(z - np.rint(z)) > 0.25
    assert np.mean(half) < 0.05  # landings are a few strides each
    k = np.abs(st["dz_m"][(np.abs(st["dz_m"]) > 1e-12) & ~on_toe]) / plan.riser_m  # risers per stair stride
    np.testing.assert_allclose(k, np.rint(k), atol=1e-9)
    assert set(np.rint(k).astype(int)) <= {1, 2}
    assert np.rint(z).min() == 0 and np.rint(z).max() <= plan.storeys - 1
    assert np.rint(z).max() >= 1  # a 30 min search leaves the ground floor


@pytest.mark.parametrize("seed", [11, 12])
def test_search_ends_outside_the_entry(walks, seed):
    pb = walks[seed]
    plan = pb.plan
    st, ends = _ends(pb)
    np.testing.assert_allclose(ends[-1], 0.0, atol=1e-9)  # the start, 5 m outside the entry
    ex, ey = plan.to_nav(*plan.entry)
    near = np.hypot(ends[:, 0] - ex, ends[:, 1] - ey) < 1.0
    assert near[: len(near) // 10].any() and near[-len(near) // 10:].any()  # in at the start, out at the end


def test_search_has_every_activity(walks):
    kinds = np.concatenate([w.step_table()["kind"] for w in walks.values()])
    for name in ("walk", "crawl", "stairs_up", "stairs_down", "kneel", "stand_up"):
        assert (kinds == GAIT_CODES[name]).any(), name
    # corridors at right angles: most walking strides run along the building's axes
    pb = walks[11]
    st = pb.step_table()
    walk = st["kind"] == GAIT_CODES["walk"]
    e = (st["chord_heading_rad"][walk] - pb.plan.axis_rad) % (math.pi / 2)
    e = np.minimum(e, math.pi / 2 - e)
    assert np.mean(e < math.radians(1.0)) > 0.5
    assert np.mean(np.abs(e - math.pi / 4) < math.radians(1.0)) > 0.0  # the 45 deg wing


def test_deterministic_by_seed_and_duration():
    a, b, c = _make(5, 300.0), _make(5, 300.0), _make(6, 300.0)
    ta, tb = a.step_table(), b.step_table()
    for k in ta:
        np.testing.assert_array_equal(ta[k], tb[k])
    assert len(ta["t_end_s"]) != len(c.step_table()["t_end_s"]) or not np.array_equal(
        ta["length_m"], c.step_table()["length_m"])
    for pb, d in ((a, 300.0), (c, 300.0)):
        assert d <= pb.t <= d + 2.0  # padded by standing outside; the last stride ends at most ~1 s late
    with pytest.raises(ValueError, match="60"):
        _make(5, 3700.0)


def test_simulated_recording_has_plan_truth():
    res = simulate("building", seed=3, profile="ideal", rate_hz=50.0, duration_s=300.0)
    plan = json.loads(res.attrs["building_plan"])
    h = plan["storey_height_m"]
    z = res.truth["foot_pos_n_m"][:, 2]
    np.testing.assert_array_equal(res.truth["storey"], np.rint(z / h))
    on = res.truth["on_stairs"].astype(bool)
    assert on.any() == bool((np.abs(res.steps["dz_m"]) > 0).any())
    assert math.isclose(res.attrs["building_axis_rad"], plan["axis_rad"])
