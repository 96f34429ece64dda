"""``bootnav import`` of a canonical IMU CSV in blocks writes the recording the in-memory import writes.

Every file is imported twice, ``read_any`` + ``write_result`` (the whole text in memory) and
``import_streaming`` with blocks of a few kB (so the file spans many blocks and every hazard falls in a later
block or on a boundary), and the two recordings are compared dataset by dataset, attribute by attribute,
event by event; messages and errors must be the same text.
"""

from __future__ import annotations

import gzip
import subprocess
import sys

import h5py
import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.logger.importers import read_any, write_result
from bootnav.logger.importers.stream import import_streaming

pytestmark = pytest.mark.timeout(120)

BLOCK = 4096  # bytes: a 3000-line file spans ~50 blocks
IGNORED_ATTRS = {"created_utc", "summary", "DIMENSION_LIST", "REFERENCE_LIST"}


def csv_text(n=3000, rate=100.0, seed=5, acc_only=False, t0=0.0):
    """A walking-like canonical CSV (µs-quantised clock with jitter), one line per sample."""
    rng = np.random.default_rng(seed)
    t = t0 + np.round((np.arange(n) / rate + rng.uniform(-2e-5, 2e-5, n)) * 1e6) / 1e6
    phase = 2 * np.pi * 1.8 * np.arange(n) / rate
    acc = np.c_[2 * np.sin(phase), np.cos(phase), 9.81 + 3 * np.sin(2 * phase)] + rng.normal(0, 0.05, (n, 3))
    acc[: int(rate)] = [0.1, -0.2, 9.79]  # one still second
    gyro = np.c_[4 * np.sin(phase + 1), 0.5 * np.cos(phase), 0.2 * np.sin(phase)]
    cols = [t[:, None], acc] + ([] if acc_only else [gyro])
    header = "t_s,ax_mps2,ay_mps2,az_mps2" + ("" if acc_only else ",gx_radps,gy_radps,gz_radps")
    rows = np.hstack(cols)
    return [header] + [",".join(f"{v:.6f}" for v in r) for r in rows]


def dump(path):
    """Every dataset and attribute of a recording (attributes that name the writing time excluded)."""
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                out[name] = obj[()]
            out[name + "@"] = {k: obj.attrs[k] for k in obj.attrs if k not in IGNORED_ATTRS}
        f.visititems(visit)
        out["@"] = {k: f.attrs[k] for k in f.attrs if k not in IGNORED_ATTRS}
    return out


def assert_same_recording(a, b):
    da, db = dump(a), dump(b)
    assert da.keys() == db.keys()
    for key, x in da.items():
        y = db[key]
        if isinstance(x, dict):
            assert x.keys() == y.keys(), key
            for k in x:
                assert np.array_equal(np.asarray(x[k]), np.asarray(y[k]),
                                      equal_nan=np.asarray(x[k]).dtype.kind == "f"), (key, k, x[k], y[k])
        elif x.dtype.names:
            assert x.dtype == y.dtype and x.shape == y.shape, key
            for name in x.dtype.names:
                assert np.array_equal(x[name], y[name], equal_nan=x[name].dtype.kind == "f"), (key, name)
        else:
            assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), key


def import_both(tmp_path, lines_or_bytes, name="walk.csv", *, newline=True, **overrides):
    src = tmp_path / name
    data = lines_or_bytes if isinstance(lines_or_bytes, bytes) else \
        ("\n".join(lines_or_bytes) + ("\n" if newline else "")).encode()
    src.write_bytes(gzip.compress(data, mtime=0) if name.endswith(".gz") else data)
    whole = read_any(src, **overrides)
    write_result(whole, tmp_path / "whole.h5")
    streamed = import_streaming(src, tmp_path / "streamed.h5", block_bytes=BLOCK, **overrides)
    assert streamed is not None
    assert streamed.messages == whole.messages
    assert_same_recording(tmp_path / "whole.h5", tmp_path / "streamed.h5")
    return whole


def test_a_clean_file_in_many_blocks(tmp_path):
    whole = import_both(tmp_path, csv_text())
    assert whole.n == 3000 and whole.events == []


def test_hazards_in_later_blocks(tmp_path):
    """Bad lines, NaN, a duplicate and a backward time, a gap, CRLF lines and a blank line, all far past the
    first block; a truncated last line without newline."""
    lines = csv_text()
    lines[1500] = lines[1500][:20]  # wrong field count
    lines[1700] = lines[1700].replace(",", ",x", 1)  # not a number
    lines[1900] = ",".join(["nan" if i == 2 else v for i, v in enumerate(lines[1900].split(","))])
    lines[2100] = lines[2099]  # duplicate time (and a repeated row)
    t = lines[2300].split(",")
    lines[2300] = ",".join([f"{float(t[0]) - 0.05:.6f}"] + t[1:])  # time goes back
    del lines[2500:2505]  # a gap of 5 samples
    lines[2600] += "\r"
    lines.insert(2700, "")
    lines[-1] = lines[-1][:15]  # truncated, no newline
    whole = import_both(tmp_path, lines, newline=False)
    kinds = sorted(e["kind"] for e in whole.events)
    assert kinds.count("skipped_line") == 4 and "duplicate_time" in kinds and "nonmonotonic_time" in kinds
    gaps = {e["line"]: e["count"] for e in whole.events if e["kind"] == "gap"}
    assert gaps[2501] == 5 and gaps[1502] == 1  # the deleted lines; a skipped line is a lost sample too
    skipped = {e["line"]: e["detail"] for e in whole.events if e["kind"] == "skipped_line"}
    assert sorted(skipped) == [1501, 1701, 1901, len(lines)]  # line numbers in the file, header = line 1
    assert skipped[len(lines)].startswith("truncated last line")


def test_gzip_acc_only_epoch_clock_and_repeated_rows(tmp_path):
    lines = csv_text(acc_only=True, t0=1.7e9)
    for i in range(1001, 1101):  # 100 stale rows (> 1 %): the values of the row before, a new time
        lines[i] = ",".join(lines[i].split(",")[:1] + lines[i - 1].split(",")[1:])
    whole = import_both(tmp_path, lines, name="acc.csv.gz", mount="waist")
    assert whole.meta["gyro_present"] == 0 and whole.meta["start_utc"].startswith("2023-11-14")
    assert any(e["kind"] == "note" and "repeat" in e["detail"] for e in whole.events)


def rewritten(lines, change):
    rows = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    change(rows)
    return [lines[0]] + [",".join(f"{v:.6f}" for v in r) for r in rows]


def in_g(rows):
    rows[:, 1:4] /= 9.80665  # acc in g under a m/s^2 header


def spike(rows):
    rows[2222, 5] = 80.0  # rad/s, beyond the physical bound, in a later block


@pytest.mark.parametrize("change, message", [(in_g, "gravity check failed"), (spike, "gyro of sample 2222")])
def test_errors_and_overridden_checks_are_the_same(tmp_path, change, message):
    text = rewritten(csv_text(), change)
    src = tmp_path / "bad.csv"
    src.write_text("\n".join(text) + "\n")
    with pytest.raises(InputError) as whole:
        read_any(src)
    with pytest.raises(InputError) as streamed:
        import_streaming(src, tmp_path / "x.h5", block_bytes=BLOCK)
    assert str(streamed.value) == str(whole.value) and message in str(whole.value)
    assert list(tmp_path.iterdir()) == [src]  # nothing left behind
    import_both(tmp_path, text, check_units=False)  # overridden: the same notes


def test_too_many_bad_lines_is_the_same_error(tmp_path):
    lines = csv_text(n=400)
    lines[200:] = ["1,2"] * len(lines[200:])
    src = tmp_path / "garbage.csv"
    src.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError) as whole:
        read_any(src)
    with pytest.raises(InputError) as streamed:
        import_streaming(src, tmp_path / "x.h5", block_bytes=BLOCK)
    assert str(streamed.value) == str(whole.value) and "data lines are malformed" in str(whole.value)


def test_concatenated_gzip_members_and_trailing_bytes(tmp_path):
    """Two gzip members (``cat a.gz b.gz``) are one file; bytes after the last member are ignored, as
    ``csvio.decompress`` ignores them (the hash still covers the whole file)."""
    text = ("\n".join(csv_text()) + "\n").encode()
    cut = text.index(b"\n", len(text) // 2) + 1
    data = gzip.compress(text[:cut], mtime=0) + gzip.compress(text[cut:], mtime=0) + b"\0\0junk"
    src = tmp_path / "two.csv.gz"
    src.write_bytes(data)
    write_result(read_any(src), tmp_path / "whole.h5")
    assert import_streaming(src, tmp_path / "streamed.h5", block_bytes=BLOCK) is not None
    assert_same_recording(tmp_path / "whole.h5", tmp_path / "streamed.h5")


def test_what_does_not_stream_is_left_to_the_in_memory_import(tmp_path):
    src = tmp_path / "walk.csv"
    src.write_text("\n".join(csv_text(n=300)) + "\n")
    assert import_streaming(src, tmp_path / "a.h5", profile="canonical_imu_csv") is None
    assert import_streaming(src, tmp_path / "a.h5", acc_unit="g") is None
    other = tmp_path / "other.csv"
    other.write_text("time,ax,ay,az\n0,0,0,1\n")
    assert import_streaming(other, tmp_path / "a.h5") is None
    cut = tmp_path / "cut.csv.gz"
    cut.write_bytes(gzip.compress(("\n".join(csv_text(n=3000)) + "\n").encode())[:-4000])
    assert import_streaming(cut, tmp_path / "a.h5", block_bytes=BLOCK) is None  # damaged: in memory
    assert not (tmp_path / "a.h5").exists()


def test_the_cli_streams_and_a_fresh_process_reads_the_same_recording(tmp_path):
    lines = csv_text()
    lines[2000] = "garbage"
    src = tmp_path / "walk.csv"
    src.write_text("\n".join(lines) + "\n")
    write_result(read_any(src), tmp_path / "whole.h5")
    run = subprocess.run([sys.executable, "-m", "bootnav.cli", "import", str(src), "--out", str(tmp_path / "cli.h5")],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert "walk.csv:2001: 1 fields, expected 7" in run.stdout
    check = subprocess.run([sys.executable, "-c", "import sys; from tests.test_import_stream import "
                            "assert_same_recording as a; a(sys.argv[1], sys.argv[2])", str(tmp_path / "whole.h5"),
                            str(tmp_path / "cli.h5")], capture_output=True, text=True, timeout=60)
    assert check.returncode == 0, check.stderr
