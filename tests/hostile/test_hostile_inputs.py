"""Issue 27: non-regular files, ranges where values are parsed, units and shapes checked by every HDF5 reader,
messages about the input instead of "unexpected ..."."""

from __future__ import annotations

import gzip
import os
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from bootnav.cli import main
from bootnav.errors import InputError

REC = Path(__file__).resolve().parents[2] / "recordings" / "sim_paper-straight.h5"


def _rec(tmp_path, name="rec.h5") -> Path:
    p = tmp_path / name
    shutil.copy(REC, p)
    return p


def run(argv, capsys) -> tuple[int, str]:
    code = main([str(a) for a in argv])
    cap = capsys.readouterr()
    err = cap.err + cap.out
    assert "unexpected" not in err.lower() and "internal error" not in err and "Traceback" not in err
    return code, err


# ------------------------------------------------------------------------------------------ non-regular files
@pytest.mark.timeout(30)
@pytest.mark.parametrize("argv", [
    ["info", "{fifo}"], ["import", "{fifo}", "--out", "{tmp}/x.h5"], ["process", "{fifo}", "--out", "{tmp}/o"],
    ["pdr", "{fifo}", "--out", "{tmp}/o"], ["process", "{rec}", "--settings", "{fifo}", "--out", "{tmp}/o"],
    ["info", "/dev/zero"],
])
def test_special_files_are_refused_at_once(tmp_path, capsys, argv):
    fifo = tmp_path / "pipe.h5"
    os.mkfifo(fifo)
    rec = _rec(tmp_path)
    argv = [a.replace("{fifo}", str(fifo)).replace("{tmp}", str(tmp_path)).replace("{rec}", str(rec)) for a in argv]
    code, err = run(argv, capsys)
    assert code == 1 and ("FIFO" in err or "device" in err)


def test_readers_refuse_a_fifo_in_the_api(tmp_path):
    import bootnav

    fifo = tmp_path / "pipe.h5"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="FIFO"):
        bootnav.load(fifo)


# ------------------------------------------------------------------------------------------ ranges
@pytest.mark.parametrize("argv, words", [
    (["simulate", "--scenario", "shuffle", "--duration", "1e9", "--out", "{tmp}/s.h5"], "--duration 1e+09: must be"),
    (["simulate", "--scenario", "shuffle", "--rate", "0", "--out", "{tmp}/s.h5"], "--rate 0: must be"),
    (["process", "{rec}", "{rec2}", "--jobs", "-3", "--out", "{tmp}/o"], "--jobs -3: must be a whole number with 1 <="),
    (["eval", "{tmp}", "--jobs", "0", "--out", "{tmp}/e"], "--jobs 0"),
    (["pdr", "{rec}", "--step-length", "0", "--out", "{tmp}/o"], "--step-length 0: must be a number with 0.1 <="),
    (["pdr", "{rec}", "--step-length", "1e9", "--out", "{tmp}/o"], "<= 3 m"),
    (["pdr", "{rec}", "--weinberg-k", "-1", "--out", "{tmp}/o"], "--weinberg-k -1"),
    (["pdr", "{rec}", "--height", "0", "--out", "{tmp}/o"], "--height 0"),
    (["process", "{rec}", "--geo-anchor", "45,9,nan", "--out", "{tmp}/o"], None),
    (["record", "--port", "loop://", "--out", "{tmp}/r.h5", "--duration", "1e9"], "--duration"),
])
def test_flags_are_range_checked_where_parsed(tmp_path, capsys, argv, words):
    rec, rec2 = _rec(tmp_path), _rec(tmp_path, "rec2.h5")
    argv = [a.replace("{rec}", str(rec)).replace("{rec2}", str(rec2)).replace("{tmp}", str(tmp_path)) for a in argv]
    try:
        code, err = run(argv, capsys)
    except SystemExit as exc:  # argparse: a usage error (exit 2) for a malformed --geo-anchor
        code, err = exc.code, capsys.readouterr().err
        assert "finite" in err
    assert code in (1, 2)
    if words:
        assert words in err
    assert not (tmp_path / "o").exists() and not (tmp_path / "s.h5").exists()


@pytest.mark.parametrize("settings, words", [
    ('{"checks": {"max_gap_s": 3600}}', "max_gap_s 3600: must be a number with 0 <= X <= 5 s"),
    ('{"checks": {"max_stride_length_m": 1e6}}', "max_stride_length_m"),
    ('{"checks": {"min_stance_fraction": 2}}', "min_stance_fraction 2: must be"),
    ('{"filter": {"sigma_acc_mps2": -1}}', "sigma_acc_mps2 -1"),
    ("[" * 100000 + "]" * 100000, "nested too deeply"),
])
def test_settings_values_are_range_checked(tmp_path, capsys, settings, words):
    rec = _rec(tmp_path)
    f = tmp_path / "s.json"
    f.write_text(settings)
    code, err = run(["process", rec, "--settings", f, "--out", tmp_path / "o"], capsys)
    assert code == 1 and words in err and str(f) in err


def test_every_default_setting_is_inside_its_range():
    from bootnav.postproc.pdr.pipeline import PdrSettings
    from bootnav.postproc.settings import ProcessSettings

    ProcessSettings.from_dict(ProcessSettings().to_dict())  # raises when a default breaks its own range
    PdrSettings().validate()


def test_import_rate_is_checked_against_the_time_column(tmp_path, capsys):
    csv = tmp_path / "timed.csv"
    csv.write_text("t_s,ax,ay,az,gx,gy,gz\n" + "\n".join(
        f"{i / 100:.2f},0.1,0.2,9.8,0.01,0.02,0.03" for i in range(500)) + "\n")
    code, err = run(["import", csv, "--rate", "1e9", "--acc-unit", "mps2", "--gyro-unit", "radps",
                     "--out", tmp_path / "a.h5"], capsys)
    assert code == 1 and "--rate 1e+09" in err
    code, err = run(["import", csv, "--rate", "1000", "--acc-unit", "mps2", "--gyro-unit", "radps",
                     "--out", tmp_path / "b.h5"], capsys)
    assert code == 1 and "contradicts the time column" in err and "100 Hz" in err
    assert not (tmp_path / "a.h5").exists() and not (tmp_path / "b.h5").exists()


# ------------------------------------------------------------------------------------------ units and shapes
def _scaled(tmp_path, name, dataset, value):
    p = _rec(tmp_path, name)
    with h5py.File(p, "r+") as f:
        if value is None:
            del f[dataset].attrs["scale_to_si"]
        else:
            f[dataset].attrs["scale_to_si"] = value
    return p


@pytest.mark.parametrize("name, dataset, value, words", [
    ("acc_g.h5", "imu/acc", 1 / 2048, "fits acc unit g"),  # int16 counts at +-16 g -> g
    ("gyro_dps.h5", "imu/gyro", 1 / 16.4, "gyro check failed"),  # counts at +-2000 dps -> deg/s
    ("counts.h5", "imu/acc", None, "gravity check failed"),  # raw counts, no scale attribute
])
def test_every_hdf5_reader_checks_units(tmp_path, capsys, name, dataset, value, words):
    import bootnav
    from bootnav.logger.recording import load

    p = _scaled(tmp_path, name, dataset, value)
    with pytest.raises(InputError, match="not in SI units"):
        load(p, check_units=True)
    assert load(p).n > 0  # read as it is for inspection and conversion (info, import)
    with pytest.raises(InputError, match=words):
        bootnav.process(str(p))
    for extra in ([], ["--chunk-s", "10"]):  # the whole-array and the block-by-block reader
        code, err = run(["process", p, "--out", tmp_path / "o", "--no-plots", *extra], capsys)
        assert code == 1 and words in err and not (tmp_path / "o").exists()
    code, err = run(["info", p], capsys)  # info shows the file, with the problem as a warning
    assert code == 0 and "warning: units:" in err and words in err
    with h5py.File(p, "r+") as f:  # imported on purpose with --trust-units: the user's decision stands
        f["meta"].attrs["unit_check"] = "overridden: gravity check failed"
    assert load(p, check_units=True).n > 0


def test_info_says_when_datasets_have_different_lengths(tmp_path, capsys):
    p = _rec(tmp_path)
    with h5py.File(p, "r+") as f:
        n = f["imu/gyro"].shape[0]
        f["imu/gyro"].resize if False else None
        data = f["imu/gyro"][: n // 2]
        attrs = {k: v for k, v in f["imu/gyro"].attrs.items() if k not in ("DIMENSION_LIST",)}
        del f["imu/gyro"]
        ds = f["imu"].create_dataset("gyro", data=data)
        ds.attrs.update(attrs)
    code, err = run(["info", p], capsys)
    assert code == 0 and "different lengths" in err and f"gyro {n // 2}" in err


def test_info_warns_about_a_cut_csv_gz(tmp_path, capsys):
    rows = "\n".join(f"{i / 100:.2f},0,0,9.81,0.01,0,0" for i in range(20000))
    full = gzip.compress(("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\n" + rows + "\n").encode())
    cut = tmp_path / "cut.csv.gz"
    cut.write_bytes(full[: len(full) // 2])
    code, err = run(["info", cut], capsys)
    assert code == 0 and "warning: the source file is cut short" in err


@pytest.mark.timeout(60)
def test_the_same_recording_twice_is_not_two_boots(tmp_path, capsys):
    import bootnav

    rec, copy = _rec(tmp_path), _rec(tmp_path, "copy.h5")
    for a, b in ((rec, rec), (rec, copy)):
        code, err = run(["process", a, b, "--two-boots", "--out", tmp_path / "o"], capsys)
        assert code == 1 and "same recording" in err
    with pytest.raises(InputError, match="same recording"):
        bootnav.process_two_boots(str(rec), str(copy))


def test_sd_header_with_an_invalid_range_code(tmp_path, capsys):
    from bootnav.logger.crc import crc16_ccitt_false
    from bootnav.logger.importers.sdlog import format_sd_header

    lines = [format_sd_header(accel_fs=9)]
    for i in range(400):
        body = f"{i * 5000},{i},0,0,2048,0,0,0,0"
        lines.append(f"{body}*{crc16_ccitt_false(body.encode()):04X}")
    log = tmp_path / "LOG00001.TXT"
    log.write_text("\n".join(lines) + "\n")
    code, err = run(["import", log, "--out", tmp_path / "sd.h5"], capsys)
    assert code == 1 and "accel_fs=9 is not a valid MPU6050 code" in err and "line 1" in err


@pytest.mark.timeout(30)
def test_live_replay_of_an_empty_recording(tmp_path, capsys):
    from bootnav.logger.recording import counts_channel, write_recording

    p = tmp_path / "empty.h5"
    write_recording(p, np.zeros(0), np.zeros((0, 3), np.int16), np.zeros((0, 3), np.int16),
                    acc_channel=counts_channel("acc", 0.0048), gyro_channel=counts_channel("gyro", 0.001),
                    measured_rate=False)
    code, err = run(["live", "--replay", p, "--http-port", "0"], capsys)
    assert code == 1 and "nothing to replay" in err


@pytest.mark.parametrize("call, words", [
    ("bootnav.process('a', 'b', 'c')", "t_s must be an array of numbers"),
    ("bootnav.process(None)", "expected a file path, a Recording"),
    ("bootnav.process(np.arange(10.0))", "give acc_mps2 and gyro_radps too"),
    ("bootnav.process(5)", "got int"),
    ("bootnav.pdr(np.arange(100) / 100, np.tile([0, 0, 9.81], (100, 1)), mag_b=np.zeros((7, 2)))",
     "expected the magnetometer as (N, 3)"),
    ("bootnav.pdr(None)", "expected a file path"),
])
def test_the_api_refuses_bad_inputs_in_its_own_words(call, words):
    import bootnav  # noqa: F401 - used by eval

    with pytest.raises(InputError) as info:
        eval(call)
    assert words in str(info.value) and "\n" not in str(info.value)
