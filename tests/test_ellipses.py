"""The scale-error covariance of the footprints (``postproc.ellipses``): first-order propagation checked
against the exact path of a walk with a known scale error."""

import numpy as np

from bootnav.postproc.ellipses import scale_error_covariance


def _walk(scale_dist: float, scale_turn: float, angle: float = 0.0):
    """An L-shaped walk (10 strides of 1 m east, a 90° turn in place, 10 m north) as footprints and yaws,
    measured with the given distance and turn scale errors and accelerometer cross-axis angle."""
    yaw_true = np.concatenate((np.zeros(11), np.full(11, np.pi / 2)))
    length = np.ones(21)
    length[10] = 0.0  # the turn in place
    yaw_est = yaw_true * (1.0 + scale_turn)
    a = yaw_est[1:] + angle
    step_true = length[:, None] * np.column_stack((np.cos(yaw_true[1:]), np.sin(yaw_true[1:])))
    step_est = (1.0 + scale_dist) * length[:, None] * np.column_stack((np.cos(a), np.sin(a)))
    fp_true = np.vstack((np.zeros(2), np.cumsum(step_true, axis=0)))
    fp_est = np.vstack((np.zeros(2), np.cumsum(step_est, axis=0)))
    return fp_true, fp_est, yaw_est


def test_covariance_is_the_outer_product_of_the_errors_each_term_makes():
    """σ² J Jᵀ with σ = s equals e eᵀ summed over the terms, e the footprint error of the walk that had only
    that error of size s (first order: s = 1e-4, agreement to 1 % of the largest entry)."""
    s = 1e-4
    fp_true, _, yaw = _walk(0.0, 0.0)
    e_a = _walk(s, 0.0)[1] - fp_true
    e_g = _walk(0.0, s)[1] - fp_true
    e_m = _walk(0.0, 0.0, s)[1] - fp_true
    for cov, errs in ((scale_error_covariance(fp_true, yaw, s, 0.0), (e_a, e_g)),
                      (scale_error_covariance(fp_true, yaw, 0.0, s), (e_m,))):
        want = sum(np.column_stack((e[:, 0] ** 2, e[:, 1] ** 2, e[:, 0] * e[:, 1])) for e in errs)
        assert np.allclose(cov, want, rtol=0, atol=0.01 * np.abs(want).max())
        assert np.abs(want).max() > 1e-7  # the walk did make an error


def test_no_error_no_covariance_and_start_is_exact():
    fp_true, _, yaw = _walk(0.0, 0.0)
    assert not scale_error_covariance(fp_true, yaw, 0.0, 0.0).any()
    cov = scale_error_covariance(fp_true, yaw, 0.01, 0.01)
    assert np.all(cov[0] == 0.0) and np.all(np.diff(cov[:, 0] + cov[:, 1]) >= 0)  # grows with the walk
