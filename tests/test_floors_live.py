"""The live view's per-stride 1-σ ellipse: the forward filter's covariance at the end of each stance phase, as
``process`` writes it into steps.csv, for any chunking; the panel shows the last one."""

from __future__ import annotations

import numpy as np
import pytest

from bootnav.postproc.live.boot import ROW_COLUMNS
from bootnav.postproc.strides import ELLIPSE_COLUMNS
from tests.test_live_view import _feed, stairs  # noqa: F401  (fixture)


@pytest.mark.parametrize("sizes", [[20], [1, 7, 333, 64]])
def test_live_rows_carry_the_ellipse_process_writes(stairs, sizes):  # noqa: F811
    rec, settings, res = stairs
    rows, statuses, view = _feed(rec, settings, sizes)
    assert view.result()["columns"] == ROW_COLUMNS and rows.shape[1] == len(ROW_COLUMNS)
    steps = res.steps
    live = rows[1:, 5:8].astype(float)
    proc = np.column_stack([steps[c] for c in ELLIPSE_COLUMNS])
    assert len(live) == len(proc)
    # the same filter on the same samples: equal up to rounding (the path within 0.5 % of the distance)
    np.testing.assert_allclose(live[:, :2], proc[:, :2], rtol=1e-3)
    elongated = proc[:, 1] < 0.9 * proc[:, 0]  # orientation is defined only for a non-circular ellipse
    d = np.angle(np.exp(2j * (live[elongated, 2] - proc[elongated, 2]))) / 2  # axes: modulo π
    assert np.abs(d).max() < 1e-3
    assert np.all(live[:, 0] >= live[:, 1]) and np.all(live[:, 1] > 0)
    last = view.status(0.0, True)["uncertainty_m"]  # after the end: the panel shows the last stride's
    assert last == [pytest.approx(live[-1, 0]), pytest.approx(live[-1, 1])]
    assert any(s["uncertainty_m"] is not None for s in statuses)
