"""``bootnav eval`` on a real two-foot trial: the fused feet are scored beside the single ones, and one plot shows
both feet alone and fused and the walker, all in the fusion's common frame."""

import json

import numpy as np
import pytest

from bootnav.postproc.evaluate import runner
from bootnav.postproc.evaluate.report import plot_trial

# issue 27: a numerical fault (e.g. a sign error in the constraint) must fail within minutes, not hang for the
# suite's 10-minute default; the slowest test here takes about 20 s on a loaded 2-core machine
pytestmark = pytest.mark.timeout(120)


def test_a_two_foot_trial_plots_both_feet_and_the_walker(datasets, tmp_path):
    manifest = json.loads((datasets / "manifest.json").read_text())
    trial = next(t for t in manifest["trials"] if t["id"] == "gaitmap_example/level_walk")
    res = runner.evaluate_trial(trial, str(datasets))
    assert res.status == "ok", res.reason
    assert "two_boots_stride_mae_m" in res.metrics and "stride_mae_m" in res.metrics
    feet = res.plot_data["two boots"]["feet_xy"]
    assert set(feet) == {"left alone", "right alone", "left fused", "right fused", "walker (fused midpoint)"}
    left_name, right_name = runner.TWO_BOOT_FILES
    # the fused feet are the paths that were scored, and each foot alone is the dotted line of its own plot
    np.testing.assert_array_equal(feet["left alone"], res.plot_data[f"{left_name} (two boots)"]["single_xy"])
    np.testing.assert_array_equal(feet["right alone"], res.plot_data[f"{right_name} (two boots)"]["single_xy"])
    np.testing.assert_array_equal(feet["left fused"], res.plot_data[f"{left_name} (two boots)"]["est_xy"])
    # the walker is the midpoint of the fused feet (gaitmap has no trajectory truth: est_xy is not re-aligned)
    lf, rf, w = feet["left fused"], feet["right fused"], feet["walker (fused midpoint)"]
    assert len(w) == len(lf) and len(rf) > 0.9 * len(lf)
    mid_start = 0.5 * (lf[0] + rf[0])
    np.testing.assert_allclose(w[0], mid_start, atol=1e-9)
    # the feet of one walker: the walker stays within the bound's half of either fused foot at the end
    assert np.linalg.norm(w[-1] - lf[-1]) <= 0.5 * 1.0 + 1e-9
    paths = plot_trial(res, tmp_path)
    both = [p for p in paths if p.name.endswith("__two_boots.png")]
    assert len(both) == 1 and both[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and both[0].stat().st_size > 10_000
