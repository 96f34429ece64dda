"""``heading_aid = "auto"`` in a stream: the causal rule switches the aid on in the live view's navigator once
the strides seen so far follow a grid, and never on an out-and-back walk."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bootnav.postproc.live.boot import BootView, LiveSettings
from bootnav.postproc.live.sources import Chunk
from bootnav.simulator import custom, simulate


def _laps(pb):
    pb.stand(10.0)
    for _ in range(4):
        for x, y in ((20.0, 0.0), (20.0, 10.0), (0.0, 10.0), (0.0, 0.0)):
            pb.walk_to(x, y)
    return pb.stand(5.0)


def _out_and_back(pb):
    pb.stand(10.0)
    for _ in range(6):
        pb.walk_to(25.0, 0.0).turn_in_place(math.pi).walk_to(0.0, 0.0).turn_in_place(math.pi)
    return pb.stand(5.0)


def _view(build):
    from bootnav.postproc.settings import ProcessSettings

    res = simulate(custom("walk", build), seed=1, profile="ideal", rate_hz=100.0)
    settings = ProcessSettings()
    settings.filter.heading_aid = "auto"
    view = BootView("b", settings, LiveSettings())
    acc, gyro, sat = res.acc_mps2, res.gyro_radps, res.saturated
    for a in range(0, res.n, 250):
        sl = slice(a, a + 250)
        view.push(Chunk(res.t_s[sl], acc[sl], gyro[sl], sat[sl]), 0.0)
    view.finish()
    return view


@pytest.mark.parametrize("build, on", [(_laps, True), (_out_and_back, False)])
def test_live_auto_heading_aid(build, on):
    view = _view(build)
    k = view.result()["heading_aid_from_stride"]
    updates = view._nav.info["heading_aid_updates"]
    if on:
        assert k is not None and k >= view.settings.filter.hde_auto_min_strides  # not before it may decide
        assert updates > 0
        # the grid it holds is the walk's own (the first leg defines the path frame: 0 deg)
        ref = view._dirs.reference_rad
        assert abs(math.remainder(ref, math.pi / 2)) < math.radians(3.0)
        # per segment: the laps' straight sides are aided, the corners are not
        segs = view.result()["heading_aid_segments"]
        assert segs["aided"] > segs["not in a straight leg"] > 0
    else:
        assert k is None and updates == 0
