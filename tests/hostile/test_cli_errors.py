"""Hostile inputs through the ``bootnav`` command: one clear error line, never a traceback.

Each case is one row of a table: the command line, and a piece of the one-line message the user must
see (what is wrong and where: file, dataset path, option). Run in-process through ``bootnav.cli.main``
so the whole table takes seconds; a few cases that need a real process (a closed pipe) use one.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from bootnav.cli import Progress, SUBCOMMANDS, build_parser, main

REPO = Path(__file__).resolve().parents[2]
WALK = REPO / "recordings" / "xio_ngimu_short_walk.h5"
UNITS = ["--acc-unit", "mps2", "--gyro-unit", "radps"]


def _variant(tmp: Path, name: str, edit) -> Path:
    path = tmp / f"{name}.h5"
    shutil.copy(WALK, path)
    with h5py.File(path, "r+") as f:
        edit(f)
    return path


def _replace(where: str, value):
    def edit(f):
        del f[where]
        if isinstance(value, str):
            f.create_group(where)
        else:
            f[where] = value
    return edit


def _set_attr(where: str, key: str, value):
    def edit(f):
        f[where].attrs[key] = value
    return edit


# name -> how the recording is damaged, and what the message must name
BAD_RECORDINGS = {
    "no_gyro": (lambda f: f.__delitem__("imu/gyro"), "/imu/gyro is missing"),
    "no_acc": (lambda f: f.__delitem__("imu/acc"), "/imu/acc is missing"),
    "no_time": (lambda f: f.__delitem__("imu/t_s"), "/imu/t_s is missing"),
    "format_version_text": (_set_attr("/", "format_version", "one"), "/format_version is 'one'"),
    "format_version_float": (_set_attr("/", "format_version", 1.5), "/format_version is 1.5"),
    "scale_text": (_set_attr("imu/acc", "scale_to_si", "abc"), "scale_to_si of /imu/acc is 'abc'"),
    "scale_nan": (_set_attr("imu/gyro", "scale_to_si", np.nan), "scale_to_si of /imu/gyro"),
    "events_group": (_replace("events", "group"), "/events is not an event table"),
    "events_floats": (_replace("events", np.arange(5.0)), "/events is not an event table"),
    "imu_dataset": (_replace("imu", np.arange(5.0)), "/imu is a dataset"),
    "acc_two_columns": (lambda f: _replace("imu/acc", f["imu/acc"][:, :2])(f), "/imu/acc is float64"),
}


def _run(capsys, argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def _assert_one_line_error(code, err, needle, command):
    assert code != 0
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert lines and lines[-1].startswith(f"bootnav {command}: error: "), err
    assert needle in lines[-1], lines[-1]


@pytest.mark.parametrize("case", sorted(BAD_RECORDINGS))
@pytest.mark.parametrize("command", ["info", "pdr", "process"])
def test_damaged_recording_is_named_with_its_dataset(tmp_path, capsys, case, command):
    edit, needle = BAD_RECORDINGS[case]
    path = _variant(tmp_path, case, edit)
    argv = [command, path] + ([] if command == "info" else ["--out", tmp_path / "out"])
    code, _, err = _run(capsys, argv)
    _assert_one_line_error(code, err, needle, command)
    assert str(path.name) in err


@pytest.mark.timeout(30)
@pytest.mark.parametrize("percent", [1, 5, 50, 90, 99])
def test_cut_recording_fails_fast_with_its_size(tmp_path, capsys, percent):
    """A half-copied file: one line saying it is cut short, not minutes of SWMR retries."""
    data = WALK.read_bytes()
    path = tmp_path / f"cut{percent}.h5"
    path.write_bytes(data[: len(data) * percent // 100])
    code, _, err = _run(capsys, ["info", path])
    have = len(data) * percent // 100
    _assert_one_line_error(code, err, f"the file is cut short: only {have} of its {len(data)} bytes "
                                      f"({100 * have / len(data):.1f} %) are present", "info")


def _bad_inputs(tmp: Path) -> list[tuple[list, str, str]]:
    """(argv, command, expected piece of the message) for the option and file cases."""
    (tmp / "a_dir").mkdir()
    latin = tmp / "latin1.json"
    latin.write_bytes(b'\xff\xfe{"floor_height_m": 3}')
    csv = tmp / "walk.csv"
    csv.write_text("t,ax,ay,az,gx,gy,gz\n" + "".join(f"{i / 100},0,0,9.81,0,0,0\n" for i in range(400)))

    def settings(name, text):
        p = tmp / name
        p.write_text(text)
        return p

    out = tmp / "o"
    return [
        (["import", tmp / "a_dir", "--out", tmp / "x.h5"], "import", "a_dir"),
        (["import", csv, "--out", tmp / "a_dir", *UNITS], "import", "a_dir"),
        (["import", csv, "--out", "/proc/x.h5", *UNITS], "import", "/proc/x.h5"),
        (["process", WALK, "--out", out, "--settings", latin], "process", "not UTF-8"),
        (["process", WALK, "--out", out, "--settings", tmp / "a_dir"], "process", "a_dir"),
        (["process", WALK, "--out", out, "--reference", '{"straight_m":"abc"}'], "process", "straight_m"),
        (["process", WALK, "--out", out, "--reference", '{"straight_m":5,"height_m":true}'], "process", "height_m"),
        (["process", WALK, "--out", out, "--settings",
          settings("bool.json", '{"filter": {"sigma_acc_mps2": true}}')], "process", "sigma_acc_mps2"),
        (["process", WALK, "--out", out, "--settings",
          settings("neg.json", '{"detector": {"min_stance_s": -0.1}}')], "process", "cannot be negative"),
        (["process", WALK, "--out", out, "--settings",
          settings("int.json", '{"filter": {"n_states": 9.5}}')], "process", "n_states"),
        (["process", WALK, "--out", out, "--settings",
          settings("evil.json", '{"output": {"results_name": "../../evil"}}')], "process", "results_name"),
        (["record", "--port", "loop://", "--out", tmp / "r.h5", "--baud", "99999999999"], "record", "--baud"),
        (["record", "--port", "loop://", "--out", tmp / "r.h5", "--baud", "0"], "record", "--baud"),
        (["record", "--port", "loop://", "--out", tmp / "r.h5", "--baud", "-5"], "record", "--baud"),
        (["record", "--port", "loop://", "--out", tmp / "a_dir", "--force"], "record", "is a directory"),
        (["record", "--port", "loop://", "--out", tmp / "r.h5", "--flush-interval", "nan"], "record",
         "--flush-interval"),
    ]


def test_bad_files_and_options_give_one_line(tmp_path, capsys):
    for argv, command, needle in _bad_inputs(tmp_path):
        code, _, err = _run(capsys, argv)
        _assert_one_line_error(code, err, needle, command)
    assert not (tmp_path / "evil").exists() and not (tmp_path.parent / "evil").exists()


def test_unexpected_error_is_one_line_and_verbose_shows_traceback(capsys, monkeypatch):
    import bootnav.logger.cli_info as info

    def boom(args):
        raise RuntimeError("simulated bug\nsecond line")

    monkeypatch.setattr(info, "run", boom)
    code, _, err = _run(capsys, ["info", WALK])
    assert code == 1 and "Traceback" not in err
    # issue 27: a bug is called a bug (no "unexpected ..."), with what to send
    assert err.strip() == ("bootnav info: error: internal error, a bug in bootnav (RuntimeError: simulated bug); "
                           "please report it with the output of --verbose")
    code, _, err = _run(capsys, ["info", WALK, "--verbose"])
    assert code == 1 and "Traceback" in err and "simulated bug" in err
    code, _, err = _run(capsys, ["--verbose", "info", WALK])  # before the subcommand too
    assert code == 1 and "Traceback" in err


def test_every_subcommand_accepts_verbose_and_quiet():
    parser = build_parser()
    for name in SUBCOMMANDS:
        for flags in (["--verbose"], ["--quiet"], ["--verbose", "--quiet"]):
            with pytest.raises(SystemExit) as exc:  # --help after the flags: parsing got that far
                parser.parse_args([name, *flags, "--help"])
            assert exc.value.code == 0


def test_quiet_before_the_subcommand_reaches_it(monkeypatch, capsys):
    import bootnav.logger.cli_info as info

    seen = {}
    monkeypatch.setattr(info, "run", lambda args: seen.update(quiet=args.quiet, verbose=args.verbose) or 0)
    assert main(["--quiet", "info", str(WALK)]) == 0 and seen == {"quiet": True, "verbose": False}
    assert main(["info", str(WALK), "--verbose"]) == 0 and seen == {"quiet": False, "verbose": True}


def test_closed_pipe_exits_quietly():
    """``bootnav info X | head -1``: no BrokenPipeError traceback, exit 141 like a shell tool."""
    code = (
        "import sys, bootnav.logger.cli_info as m\n"
        "def run(args):\n"
        "    for _ in range(100000): print('line of output ' * 4)\n"
        "m.run = run\n"
        "from bootnav.cli import main\n"
        "sys.exit(main(['info', sys.argv[1]]))\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code, str(WALK)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, cwd=REPO)
    proc.stdout.readline()
    proc.stdout.close()  # what `head -1` does after its line
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141
    assert err == ""


def test_progress_is_plain_lines_in_a_log(tmp_path):
    log_path = tmp_path / "log.txt"
    with open(log_path, "w") as log:
        p = Progress(log, log_interval_s=0.0)
        for k in range(3):
            p.update(f"step {k}")
        p.done("finished")
    text = log_path.read_text()
    assert "\r" not in text and text.splitlines() == ["step 0", "step 1", "step 2", "finished"]
    with open(log_path, "w") as log:
        Progress(log, quiet=True).update("hidden", force=True)
    assert log_path.read_text() == ""


def test_simulate_progress_in_a_log_has_no_carriage_return(tmp_path):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.run([sys.executable, "-m", "bootnav", "simulate", "--scenario", "paper-straight",
                           "--out", str(tmp_path / "s.h5")], capture_output=True, text=True, cwd=REPO,
                          env=env, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "\r" not in proc.stderr and "\r" not in proc.stdout


@pytest.mark.parametrize("edit, warning", [
    (lambda f: f["imu/acc"].__setitem__(slice(10, 12), np.nan), "acc: 2 non-finite samples (first at sample 10)"),
    (lambda f: f["imu/gyro"].__setitem__(Ellipsis, 0.0), "gyro: all zero"),
    (lambda f: (f["imu/gyro"].__setitem__(Ellipsis, 0.001), f["imu/acc"].__setitem__(Ellipsis, [0.0, 0.0, 9.81])),
     "no motion"),
])
def test_info_warns_about_unusable_data(tmp_path, capsys, edit, warning):
    path = _variant(tmp_path, "odd", edit)
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"WARNING     {warning}" in out
    assert main(["info", str(WALK)]) == 0
    assert "WARNING" not in capsys.readouterr().out  # a real walk raises none


def test_emulator_refuses_impossible_numbers(tmp_path, capsys):
    for flag, value in (("--rate", "-5"), ("--duration", "nan"), ("--write-timeout", "0")):
        code, _, err = _run(capsys, ["emulate", "--out-link", tmp_path / "b", "--no-wait", flag, value])
        _assert_one_line_error(code, err, flag, "emulate")
    assert not (tmp_path / "b").exists()


def test_process_refuses_non_finite_samples_naming_the_first(tmp_path, capsys):
    path = _variant(tmp_path, "inf", lambda f: f["imu/gyro"].__setitem__((1234, 2), np.inf))
    code, _, err = _run(capsys, ["process", path, "--out", tmp_path / "out"])
    _assert_one_line_error(code, err, "sample 1234 (t = ", "process")
    assert "NaN/inf in gz" in err


@pytest.mark.parametrize("edit, needle", [
    (lambda f: f["imu/acc"].__setitem__(Ellipsis, np.nan), "acc of sample 0 (t = 0 s) is not finite (16539 samples)"),
    (lambda f: f["imu/gyro"].__setitem__((500, 1), np.inf), "gyro of sample 500 (t = "),
])
def test_pdr_refuses_non_finite_samples(tmp_path, capsys, edit, needle):
    path = _variant(tmp_path, "nonfinite", edit)
    code, _, err = _run(capsys, ["pdr", path, "--out", tmp_path / "out"])
    _assert_one_line_error(code, err, needle, "pdr")
    assert not (tmp_path / "out").exists()


def test_top_level_help_is_for_users(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert "``" not in out and "Exit status" in out and "--verbose" in out
