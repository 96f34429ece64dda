"""One place for each default: a command-line flag whose value has a home in a settings class has no argparse
default of its own (``None``: the class's default applies) and the number its help text shows is the class's.
A changed default then changes every command at once, and a stale help text fails here."""

from __future__ import annotations

import math
import re

import pytest

from bootnav.cli import build_parser
from bootnav.logger.serial_recorder import MultiRecorderSettings, RecorderSettings
from bootnav.postproc.calibration import CalibrationSettings
from bootnav.postproc.sensorcal.settings import SensorCalSettings
from bootnav.postproc.settings import ProcessSettings
from bootnav.postproc.strides import FloorSettings
from bootnav.simulator.simulate import DEFAULT_PROFILE, DEFAULT_RATE_HZ, DEFAULT_SEED, simulate
from bootnav.simulator.twoboots import simulate_two_boots


def _action(command: str, flag: str):
    sub = next(a for a in build_parser()._actions if a.dest == "command" or getattr(a, "choices", None)
               and command in (a.choices or {}))
    parser = sub.choices[command]
    return next(a for a in parser._actions if flag in a.option_strings)


R, S, P, C = RecorderSettings("p", "o"), SensorCalSettings(), ProcessSettings(), CalibrationSettings()


@pytest.mark.parametrize("command, flag, default", [
    ("record", "--baud", R.baud),
    ("record", "--flush-interval", R.flush_interval_s),
    ("record", "--header-wait", R.header_wait_s),
    ("record", "--connect-timeout", R.connect_timeout_s),
    ("live", "--baud", R.baud),
    ("calibrate", "--baud", R.baud),
    ("calibrate", "--goal-scale", S.goal_scale_sigma * 100.0),  # the flag is in percent
    ("calibrate", "--goal-misalignment", math.degrees(S.goal_misalignment_sigma_rad)),  # the flag is in degrees
    ("calibrate", "--latitude", S.latitude_deg),
    ("process", "--latitude", C.latitude_deg),
    ("process", "--height", C.height_m),
    ("process", "--floor-height", P.floor_height_m),
    ("process", "--stair-min-dz", P.floor_stair_min_dz_m),
    ("process", "--block-s", P.block_s),
    ("simulate", "--seed", DEFAULT_SEED),
    ("simulate", "--rate", DEFAULT_RATE_HZ),
    ("simulate", "--sensor-profile", DEFAULT_PROFILE),
])
def test_a_flag_takes_its_default_from_the_settings_and_says_it(command, flag, default):
    action = _action(command, flag)
    assert action.default is None, f"{command} {flag}: argparse default {action.default!r} beside the settings' one"
    shown = re.search(r"default:? (-?[0-9][0-9_.e+-]*)", action.help or "")
    if isinstance(default, str):  # a name: the help shows it as it is
        assert f"default {default}" in (action.help or ""), (command, flag, action.help)
    elif shown is not None:  # a help text that shows a number shows the settings' number
        assert float(shown.group(1).rstrip(".")) == pytest.approx(default, rel=1e-12), (command, flag, action.help)


def test_the_multi_boot_recorder_shares_the_single_recorders_defaults():
    m = MultiRecorderSettings(["a", "b"], ["l", "r"], "o")
    for name in ("baud", "flush_interval_s", "header_wait_s", "connect_timeout_s", "status_interval_s"):
        assert getattr(m, name) == getattr(R, name)


def test_simulate_and_its_flags_share_one_set_of_defaults():
    """``bootnav simulate`` without --seed/--sensor-profile/--rate runs ``simulate()`` with its own defaults,
    and the two-boot simulation takes the same ones."""
    import argparse
    import inspect

    from bootnav.simulator.cli import simulate_defaults

    args = argparse.Namespace(seed=None, sensor_profile=None, rate=None)
    simulate_defaults(args)
    for fn in (simulate, simulate_two_boots):
        p = inspect.signature(fn).parameters
        assert (p["seed"].default, p["profile"].default, p["rate_hz"].default) == \
            (args.seed, args.sensor_profile, args.rate), fn.__name__


def test_floor_defaults_have_one_home():
    """``ProcessSettings.floor_*`` are ``strides.FloorSettings``'s defaults (before, ``FloorSettings()`` had
    no stair gate and no storeys while every run used both), and the storeys' functions default to them."""
    import inspect

    from bootnav.postproc.floors import snap_storeys, storey_numbers, storey_offsets

    assert P.floor_settings() == FloorSettings()
    for fn in (storey_offsets, snap_storeys):
        p = inspect.signature(fn).parameters
        assert (p["min_stride_m"].default, p["storey_merge_m"].default, p["storey_m"].default) == \
            (P.filter.level_min_stride_m, P.floor_hysteresis_m, P.floor_height_m), fn.__name__
    assert inspect.signature(storey_numbers).parameters["storey_m"].default == P.floor_height_m


#: Known, owned elsewhere: ``ProcessResult.gravity_mps2`` in ``postproc/pipeline.py`` (helper "onepipe2"
#: rewrites that file; it should read ``STANDARD_GRAVITY_MPS2``).
KNOWN_GRAVITY_LITERALS = {"postproc/pipeline.py"}


def test_standard_gravity_is_written_once():
    """The number 9.80665 appears in code only as ``core.conventions.STANDARD_GRAVITY_MPS2`` (docstrings and
    comments may say it)."""
    import io
    import tokenize

    from tests.conftest import REPO

    found = []
    for folder in ("bootnav", "logger", "postproc", "simulator"):
        for f in (REPO / folder).rglob("*.py"):
            rel = f.relative_to(REPO).as_posix()
            tokens = tokenize.generate_tokens(io.StringIO(f.read_text(encoding="utf-8")).readline)
            if any(t.type == tokenize.NUMBER and t.string.replace("_", "").startswith("9.80665") for t in tokens):
                found.append(rel)
    assert sorted(set(found) - KNOWN_GRAVITY_LITERALS) == ["bootnav/core/conventions.py"]
