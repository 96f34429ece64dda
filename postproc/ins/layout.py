"""Layout of the filter's state vectors, named once for both engines, the measurement models and the smoother.

Nominal state ``st`` (one float64 vector, updated in place by the numba kernel; the reference engine keeps the
same vector): position p_n (m), velocity v_n (m/s), attitude q_nb (wxyz), accelerometer bias b_a (body, m/s²),
gyro bias b_g (body, rad/s), then the memory of the optional heading aid (``measurements.heading_aid``) and of
the level-stride height hold (``measurements.level_height``).

Error state δx = x_true − x̂ (``filter.py``): δp_n, δv_n, δθ_n (nav-frame attitude error, rad), and with 15
states δb_a, δb_g. ``DP … DBG`` are the first indices of these 3-blocks, ``ERR_P … ERR_BG`` the blocks as
slices; ``YAW`` is δθ_U, ``HEIGHT`` δp_U.

Numba kernels index element-wise (``st[VEL.start + i]``, ``P[DV + i, m]``): the slices are frozen as
compile-time constants, so a named index costs nothing.
"""

from __future__ import annotations

import numpy as np

# nominal state
POS = slice(0, 3)
VEL = slice(3, 6)
QUAT = slice(6, 10)
BIAS_ACC = slice(10, 13)
BIAS_GYRO = slice(13, 16)
# heading-aid memory: horizontal position at the previous stance onset, whether there was one (1.0 / 0.0),
# and the reference heading (rad, NaN until the first long enough stride sets it)
HDE_PREV_X, HDE_PREV_Y, HDE_HAVE_PREV, HDE_REF_HEADING = 16, 17, 18, 19
# level-stride memory (``measurements.level_height``): the reference height (m: the floor the foot stands on),
# whether there is one (1.0 / 0.0), and whether it follows the foot to the end of the current stance phase
# (1.0 after a stride that was not level: the new floor's height is where the foot settles), and the horizontal
# position at the last stance sample (the start of the next stride)
LVL_REF_Z, LVL_HAVE_REF, LVL_PENDING, LVL_LAST_X, LVL_LAST_Y = 20, 21, 22, 23, 24
# the heading aid's per-segment gate (1.0: it may apply its measurement; 0.0: it only keeps its memory): set
# between pushes by the engines from ``run_filter``'s ``heading_gate`` (``building.directions``), 1.0 by default
HDE_GATE = 25
N_NOMINAL = 26

# error state: first index of each 3-block (numba kernels), and the blocks as slices (NumPy code)
DP, DV, DTH, DBA, DBG = 0, 3, 6, 9, 12
YAW = DTH + 2
HEIGHT = DP + 2
ERR_P, ERR_V, ERR_TH, ERR_BA, ERR_BG = (slice(i, i + 3) for i in (DP, DV, DTH, DBA, DBG))


def initial_nominal_state(q0_nb, acc_bias0_b, gyro_bias0_b, hde_reference_rad: float | None = None) -> np.ndarray:
    """Nominal state at sample 0: origin, at rest, the given attitude and biases, no heading-aid memory.

    Parameters
    ----------
    q0_nb : (4,) initial attitude, wxyz, unit norm.
    acc_bias0_b, gyro_bias0_b : (3,) initial sensor biases (body frame; m/s², rad/s).
    hde_reference_rad : the heading aid's grid direction when decided beforehand (rad); None: the first
        long enough stride sets it.

    Returns
    -------
    (N_NOMINAL,) float64 vector laid out as this module says.
    """
    st = np.zeros(N_NOMINAL)
    st[QUAT] = q0_nb
    st[BIAS_ACC] = acc_bias0_b
    st[BIAS_GYRO] = gyro_bias0_b
    st[HDE_REF_HEADING] = np.nan if hde_reference_rad is None else float(hde_reference_rad)
    st[HDE_GATE] = 1.0
    return st
