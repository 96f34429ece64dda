"""A ``bootnav process`` flag that another flag (or the kind of run) makes meaningless is refused with one line
naming both, never silently ignored (issue 25: "a flag the chosen detector ignores is an error")."""

from __future__ import annotations

import argparse

import pytest

from bootnav.cli import main
from bootnav.errors import InputError
from bootnav.postproc import cli_process
from tests.conftest import REPO

REC = REPO / "recordings" / "gaitmap_level_walk_left.h5"


def _settings(*argv: str):
    p = argparse.ArgumentParser()
    cli_process.add_arguments(p)
    return cli_process.build_settings(p.parse_args(["x.h5", "--out", "o", *argv]))


@pytest.mark.parametrize("argv, message", [
    (["--gravity", "9.81", "--latitude", "10"], "--gravity with --latitude"),
    (["--gravity", "9.81", "--height", "100"], "--gravity with --height"),
    (["--floors-from-height", "--stair-min-dz", "0.2"], "--floors-from-height with --stair-min-dz"),
    (["--reference", "truth", "--closed-loop"], "--reference with --closed-loop"),
    (["--no-hdf5", "--into-recording"], "--no-hdf5 with --into-recording"),
    (["--no-hdf5", "--results-name", "x"], "--no-hdf5 with --results-name"),
])
def test_contradicting_flags_are_refused(argv, message):
    with pytest.raises(InputError, match="^" + message + ": "):
        _settings(*argv)


def test_each_flag_alone_is_taken():
    assert _settings("--gravity", "9.81").calibration.gravity_mps2 == 9.81
    assert _settings("--latitude", "10", "--height", "100").calibration.latitude_deg == 10
    assert _settings("--floors-from-height").floor_stair_min_dz_m is None
    assert _settings("--closed-loop").reference == '{"closed_loop": true}'
    assert _settings("--no-hdf5").output.write_hdf5 is False


@pytest.mark.parametrize("flag", [["--max-separation", "0.5"], ["--clock", "gait"], ["--right-offset-s", "0.1"],
                                  ["--boots", "a,b"], ["--two-boot-settings", "tb.json"]])
def test_a_two_boot_flag_on_a_single_foot_is_refused(flag, tmp_path, capsys):
    assert main(["process", str(REC), "--out", str(tmp_path / "o"), "--no-plots", "-q", *flag]) == 1
    err = capsys.readouterr().err
    assert f"{flag[0]} applies to two boots of one walker only" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("flag, message", [(["--boots", "a,b"], "--boots a,b: chooses two boots of one multi-boot"),
                                           (["--into-recording"], "--into-recording: a two-boot run writes")])
def test_a_flag_two_boots_ignore_is_refused(flag, message, tmp_path, capsys):
    assert main(["process", str(REC), str(REC), "--two-boots", "--out", str(tmp_path / "o"), "--no-plots", "-q",
                 *flag]) == 1
    assert message in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def _pdr_settings(*argv: str):
    from bootnav.postproc.pdr import cli as pdr_cli

    p = argparse.ArgumentParser()
    pdr_cli.add_arguments(p)
    return pdr_cli.build_settings(p.parse_args(["x.csv", "--out", "o", *argv]))


@pytest.mark.parametrize("argv, message", [
    (["--heading", "mag", "--heading0", "90"], "--heading0: heading 'mag' does not use it"),
    (["--heading", "gyro", "--declination", "5"], "--declination: heading 'gyro' does not use it"),
    (["--complementary-tau", "5"], "--complementary-tau: heading 'auto' does not use it"),
    (["--heading", "gyro", "--mag-tilt", "none"], "--mag-tilt: heading 'gyro' does not use it"),
    (["--mag-calibration", "ellipse"], "--mag-calibration: heading 'auto' does not use it"),
    (["--heading", "compass", "--gyro-signed-magnitude"], "--gyro-signed-magnitude: heading 'compass' does not"),
    (["--engineered"], "--engineered: step detector 'robust' has no literal form"),
])
def test_a_pdr_flag_the_chosen_method_ignores_is_refused(argv, message):
    with pytest.raises(InputError, match="^" + message):
        _pdr_settings(*argv)


def test_pdr_flags_their_method_reads_are_taken():
    assert _pdr_settings("--heading", "gyro", "--heading0", "90").heading0_deg == 90
    assert _pdr_settings("--heading", "complementary", "--complementary-tau", "5", "--mag-tilt", "none",
                         "--declination", "3").complementary_tau_s == 5
    assert _pdr_settings("--detector", "zero_crossing", "--engineered").detector_params["literal"] is False


@pytest.mark.parametrize("argv, message", [
    (["--two-files"], "--two-files splits a --two-boots simulation"),
    (["--two-boots", "--plot", "p.png"], "--plot is not available with --two-boots"),
    (["--two-boots", "--mount", "left_boot"], "--mount is not available with --two-boots"),
])
def test_a_simulate_flag_that_would_be_ignored_is_refused(argv, message, tmp_path, capsys):
    out = tmp_path / "w.h5"
    assert main(["simulate", "--scenario", "paper-straight", "--out", str(out), *argv]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_a_flag_value_is_checked_as_the_same_value_in_a_settings_file(tmp_path):
    """A flag goes through the settings file's checks (``settings.from_plain``): refused with the same reason,
    so the settings saved with a run always load again."""
    import json

    f = tmp_path / "s.json"
    f.write_text(json.dumps({"block_s": 1e9}))
    with pytest.raises(InputError) as from_file:
        _settings("--settings", str(f))
    with pytest.raises(InputError, match="^command line: ") as from_flag:
        _settings("--block-s", "1e9")
    assert str(from_file.value).split(": ", 1)[1] == str(from_flag.value).split(": ", 1)[1]
    assert _settings("--block-s", "600").block_s == 600
