"""The maximum-separation projection and its pseudo-measurement (postproc/twoboots/constraint.py), exactly."""

import numpy as np
import pytest

from bootnav.postproc.twoboots.constraint import position_measurement, project_max_separation

# issue 27: a numerical fault (e.g. a sign error in the constraint) must fail within minutes, not hang for the
# suite's 10-minute default; the slowest test here takes about 20 s on a loaded 2-core machine
pytestmark = pytest.mark.timeout(120)


def _spd(rng, scale):
    a = rng.normal(size=(3, 3))
    return scale * (a @ a.T + 0.1 * np.eye(3))


def test_inside_the_bound_nothing_moves():
    pl, pr = np.array([0.3, 0.0, 0.0]), np.array([-0.3, 0.1, 0.0])
    p = project_max_separation(pl, np.eye(3), pr, np.eye(3), 1.0)
    assert not p.active and p.multiplier == 0.0
    assert np.array_equal(p.p_left, pl) and np.array_equal(p.p_right, pr)


def test_equal_isotropic_covariances_move_both_feet_equally_onto_the_sphere():
    pl, pr = np.array([1.5, 0.0, 0.0]), np.array([-0.5, 0.0, 0.0])  # 2 m apart, bound 1 m
    p = project_max_separation(pl, 0.04 * np.eye(3), pr, 0.04 * np.eye(3), 1.0)
    assert p.active and p.separation_m == pytest.approx(2.0)
    np.testing.assert_allclose(p.p_left, [1.0, 0, 0], atol=1e-9)  # each moves half the excess
    np.testing.assert_allclose(p.p_right, [0.0, 0, 0], atol=1e-9)
    np.testing.assert_allclose(p.direction, [1, 0, 0], atol=1e-12)


def test_a_certain_foot_stays_and_the_other_goes_to_the_sphere_around_it():
    """P_R = 0: the resting foot is known, the swinging one is projected onto the sphere of radius γ around it
    (the sphere-limit rule of [Prateek2013] is this special case)."""
    pl, pr = np.array([2.0, 1.0, 0.5]), np.array([0.0, 0.0, 0.0])
    p = project_max_separation(pl, 0.1 * np.eye(3), pr, np.zeros((3, 3)), 1.2)
    np.testing.assert_allclose(p.p_right, pr, atol=0)
    np.testing.assert_allclose(p.p_left, 1.2 * pl / np.linalg.norm(pl), atol=1e-9)


def test_general_covariances_satisfy_the_kkt_conditions():
    rng = np.random.default_rng(3)
    for _ in range(20):
        Pl, Pr = _spd(rng, 0.05), _spd(rng, 0.02)
        pl, pr = rng.normal(size=3) * 2, rng.normal(size=3) * 2
        gamma = 0.5 * np.linalg.norm(pl - pr)
        p = project_max_separation(pl, Pl, pr, Pr, gamma, tol_m=1e-12)
        d = p.p_left - p.p_right
        assert np.linalg.norm(d) == pytest.approx(gamma, abs=1e-9)
        # stationarity: P_L^-1 (p_L - p̂_L) = -μ d and P_R^-1 (p_R - p̂_R) = +μ d with μ >= 0
        np.testing.assert_allclose(np.linalg.solve(Pl, p.p_left - pl), -p.multiplier * d, atol=1e-7)
        np.testing.assert_allclose(np.linalg.solve(Pr, p.p_right - pr), p.multiplier * d, atol=1e-7)
        assert p.multiplier > 0
        # it is the minimum: any other point on the sphere costs more
        def cost(a, b):
            return (a - pl) @ np.linalg.solve(Pl, a - pl) + (b - pr) @ np.linalg.solve(Pr, b - pr)
        best = cost(p.p_left, p.p_right)
        for _ in range(50):
            u = rng.normal(size=3)
            c = 0.5 * (p.p_left + p.p_right) + rng.normal(size=3) * 0.05
            u = u / np.linalg.norm(u) * gamma / 2
            assert cost(c + u, c - u) >= best - 1e-9


def test_the_scalar_kalman_update_reproduces_the_projection_and_reaches_correlated_states():
    """The pseudo-measurement along the constrained separation, with R -> 0, moves a filter's position
    exactly onto the projected one, moves a state correlated with the position (here a 'heading' row), and
    shrinks the position variance only along that direction."""
    rng = np.random.default_rng(7)
    n = 4  # three position states and one correlated state
    A = rng.normal(size=(n, n))
    P = A @ A.T * 0.05 + 0.01 * np.eye(n)
    Pr = _spd(rng, 0.03)
    pl, pr = np.array([1.4, 0.3, 0.0]), np.array([0.0, 0.0, 0.0])
    proj = project_max_separation(pl, P[:3, :3], pr, Pr, 1.0, tol_m=1e-12)
    z, H, R = position_measurement(pl, proj.p_left, proj.direction, n, sigma_m=1e-7)
    K = P @ H.T / (H @ P @ H.T + R)
    dx = (K @ z).ravel()
    np.testing.assert_allclose(pl + dx[:3], proj.p_left, atol=1e-9)
    assert abs(dx[3]) > 1e-6  # the correlated state moved too
    Pn = (np.eye(n) - K @ H) @ P @ (np.eye(n) - K @ H).T + K @ R @ K.T
    u = proj.direction
    assert u @ Pn[:3, :3] @ u < 1e-10 * (u @ P[:3, :3] @ u) + 1e-13
    w = np.cross(u, [0.0, 0.0, 1.0])
    w /= np.linalg.norm(w)
    assert w @ Pn[:3, :3] @ w > 0.05 * (w @ P[:3, :3] @ w)  # not collapsed across the separation
