"""Revisits (postproc.building.revisits): flight detection, revisit edges, the pose graph, the path correction."""

from dataclasses import replace
from types import SimpleNamespace

import numpy as np

from bootnav.postproc.building.revisits import apply_revisits, detect_revisits, flights, solve_graph
from bootnav.postproc.ins.settings import FilterSettings

S = replace(FilterSettings(), revisits="entry+stairs")


def _loop(n=40, side=10.0):
    """Footprints of a closed square walk (level), 1 m strides, starting and ending at the origin."""
    pts = [np.zeros(3)]
    for d in ((1, 0), (0, 1), (-1, 0), (0, -1)):
        for _ in range(int(side)):
            pts.append(pts[-1] + np.array([d[0], d[1], 0.0]))
    return np.array(pts)


def test_flights_are_runs_of_climbing_strides():
    z = np.concatenate([np.zeros(5), 0.34 * np.arange(1, 6), 1.7 * np.ones(4), 1.7 - 0.34 * np.arange(1, 3)])
    fp = np.column_stack([np.arange(len(z)), np.zeros(len(z)), z])
    # five climbing strides form a flight; two descending ones are too few to be one
    assert flights(fp, S.level_max_dz_m) == [(4, 9)]


def test_entry_edge_only_when_the_walk_ends_near_its_start():
    fp = _loop()
    assert detect_revisits(fp, S) == [(0, len(fp) - 1, "entry")]
    far = fp.copy()
    far[-1, :2] += [5.0, 0.0]  # 5 m off after 40 m: more than 3 % of the distance
    assert detect_revisits(far, S) == []


def _flight(z0, x0=0.0, y=5.0, up=True, west=False):
    """Footprints of a 9-stride flight (0.34 m, 0.56 m per stride) from (x0, y, z0), east (or west), up or down."""
    k = np.arange(10)
    z = z0 + 0.34 * (k if up else 9 - k)
    x = x0 + (-1 if west else 1) * 0.56 * (k if up else 9 - k)
    return np.column_stack([x, np.full(10, y), z])


def _level(a, b, n=5):
    return np.linspace(a, b, n)[1:-1]


def test_stacked_flights_are_tied_and_the_other_half_of_a_u_is_not():
    start = np.array([[-20.0, 5.0, 0.0]])
    f1 = _flight(0.0)
    f2 = _flight(3.06) + [0.4, 0.3, 0.0]  # the flight stacked above, seen 0.5 m off
    fp = np.vstack([start, f1, _level(f1[-1], f2[0]), f2])
    edges = detect_revisits(fp, replace(S, revisits="stairs"))
    assert len(edges) == 2 and all(k == "stairs" for *_, k in edges)
    assert {fp[i, 2] for i, j, _ in edges} | {fp[j, 2] for i, j, _ in edges} == {0.0, 3.06, 6.12}
    # down the same flight again: the same physical flight, tied
    down = _flight(0.0, up=False)
    fp_down = np.vstack([start, f1, _level(f1[-1], down[0] + [0, 0, 0]), down])
    assert len(detect_revisits(fp_down, replace(S, revisits="stairs"))) == 2
    # the U's second half: 1.2 m beside the first, climbing the other way: never tied to the first
    half = _flight(1.53, x0=5.04, y=6.2, west=True)
    fp_u = np.vstack([start, f1[:5], _level(f1[4], half[0]), half])
    assert detect_revisits(fp_u, replace(S, revisits="stairs")) == []


def test_pose_graph_spreads_a_closure_error_along_the_path():
    true = _loop()
    drift = np.column_stack([0.02 * np.arange(len(true)), np.zeros(len(true))])  # 2 cm per stride east
    est = true[:, :2] + drift
    var = np.full(len(est) - 1, 0.05**2)
    fixed = solve_graph(est, var, [(0, len(est) - 1, "entry")], 0.3)
    # least squares splits the 0.8 m gap by the variances: the loop keeps σ_c² / (σ_c² + Σ σ_k²) of it ...
    gap = est[-1] - est[0]
    kept = 0.3**2 / (0.3**2 + var.sum())
    np.testing.assert_allclose(fixed[-1] - fixed[0], kept * gap, atol=1e-9)
    # ... and with equal step variances the correction grows linearly with the stride count
    k = np.arange(len(est))[:, None]
    np.testing.assert_allclose(fixed - est, -(1 - kept) * gap * k / (len(est) - 1), atol=1e-9)
    np.testing.assert_allclose(solve_graph(est, var, [], 0.3), est, atol=1e-9)  # no revisit, no change


def test_apply_revisits_corrects_every_sample_and_keeps_the_input():
    fp = _loop()
    fp[:, 0] += 0.005 * np.arange(len(fp))  # 0.2 m off after 40 m: within the 1 % gate
    # samples: each footprint held for 5 samples (stance) with 3 swing samples between
    pos, stance, t = [], [], []
    for k, p in enumerate(fp):
        for i in range(8):
            q = p if i < 5 or k == len(fp) - 1 else p + (fp[k + 1] - p) * (i - 4) / 4
            pos.append(q)
            stance.append(i < 5)
    pos = np.array(pos)
    t = np.arange(len(pos)) * 0.1
    nav = SimpleNamespace(pos_n=pos, pos_sigma_n=None, info={})
    before = pos.copy()
    out = apply_revisits(nav, t, np.array(stance), replace(S, revisits="entry"))
    np.testing.assert_array_equal(pos, before)  # the input array is not modified
    assert out.info["revisits"]["edges"][0]["kind"] == "entry"
    # the end-to-start gap shrinks to the share the least squares leaves (test above), step σ at its 5 cm floor
    n_steps = len(fp) - 1
    kept = S.revisit_sigma_m**2 / (S.revisit_sigma_m**2 + n_steps * S.revisit_step_sigma_m**2)
    gap, after = (np.linalg.norm(p[-1, :2] - p[0, :2]) for p in (pos, out.pos_n))
    np.testing.assert_allclose(after, kept * gap, rtol=1e-6)
    np.testing.assert_array_equal(out.pos_n[:, 2], pos[:, 2])  # height untouched
