"""Issue 26, point 4: the command line as a user meets it. ``-q`` on every subcommand; a usage error exits 2
everywhere; every option says what it does, and a numeric one its unit or default."""

from __future__ import annotations

import argparse
import re
import subprocess
import sys

import pytest

from bootnav.cli import SUBCOMMANDS, build_parser, main
from tests.conftest import REPO

# a numeric option's help names its unit (SI or the unit the option takes; a count names what it counts, a
# ratio says dimensionless) and its default (or that it is required / has none)
UNIT = re.compile(r"(?<![\w-])(s|ms|us|µs|Hz|kHz|m|mm|cm|m/s|m/s\^?2|rad/s|rad|deg|°|deg/s|dps|g|MB|GB|bytes?|"
                  r"samples?|%|ppm|seconds?|metres?|degrees?|baud|bit/s|x|processes|cores|states|"
                  r"dimensionless|seed|number|(?-i:C|degC|°C))(?![\w-])", re.IGNORECASE)
DEFAULT = re.compile(r"default|required|\bnone\b", re.IGNORECASE)


def _subparsers():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices


def test_every_option_has_help_and_numeric_options_a_unit_or_default():
    missing, no_unit = [], []
    for name, p in _subparsers().items():
        for a in p._actions:
            if isinstance(a, (argparse._HelpAction, argparse._VersionAction)) or a.help == argparse.SUPPRESS:
                continue
            where = f"{name} {'/'.join(a.option_strings) or a.dest}"
            if not (a.help and a.help.strip()):
                missing.append(where)
                continue
            numeric = a.type in (int, float) or isinstance(a.default, (int, float)) and not isinstance(a.default, bool)
            text = a.help.replace("%(default)s", "default")
            if numeric and a.option_strings and not (UNIT.search(text) and DEFAULT.search(text)):
                no_unit.append(f"{where}: {a.help!r}")
    assert not missing, f"options without help text: {missing}"
    assert not no_unit, "numeric options whose help lacks a unit or a default:\n" + "\n".join(no_unit)


@pytest.mark.parametrize("name", list(SUBCOMMANDS))
def test_quiet_short_flag_on_every_subcommand(name):
    p = _subparsers()[name]
    assert "-q" in p._option_string_actions and "--quiet" in p._option_string_actions, name


def test_info_dash_q_works(capsys):
    rec = str(REPO / "recordings" / "xio_ngimu_short_walk.h5")
    assert main(["info", "-q", rec]) == 0
    assert "samples" in capsys.readouterr().out


def test_simulate_usage_error_exits_2_like_every_other_usage_error(tmp_path):
    for argv in (["simulate"], ["simulate", "--scenario", "no-such-walk", "--out", str(tmp_path / "x.h5")],
                 ["simulate", "--scenario", "paper-straight", "--mount", "hat", "--out", str(tmp_path / "x.h5")],
                 ["info", "--no-such-option"]):
        proc = subprocess.run([sys.executable, "-m", "bootnav.cli", *argv], capture_output=True, text=True,
                              timeout=60, cwd=tmp_path)
        assert proc.returncode == 2, (argv, proc.returncode, proc.stderr)
        assert "Traceback" not in proc.stderr and proc.stderr.strip()


def test_first_run_compile_notice_is_printed_once():
    """numba compiles two sets of kernels on a first run (the CSV writer's, the filter's): one notice."""
    import io

    from bootnav.postproc.cli_process import StageProgress

    err = io.StringIO()
    progress = StageProgress(stream=err)
    progress.compiling()  # the CSV writer's kernel
    progress.compiling()  # then the filter's
    lines = [ln for ln in err.getvalue().splitlines() if ln.strip()]
    assert len(lines) == 1 and "compiling" in lines[0] and "first run" in lines[0]
