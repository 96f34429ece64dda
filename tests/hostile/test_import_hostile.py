"""``bootnav import`` never destroys a file and never writes physically impossible data silently."""

from __future__ import annotations

import hashlib
from pathlib import Path

import h5py
import numpy as np
import pytest

from bootnav.cli import main
from bootnav.errors import DiskFullError
from bootnav.logger.importers.core import MAX_ACC_MPS2, MAX_GYRO_RADPS, read_any, write_result
from bootnav.logger.recording import load

UNITS = ["--acc-unit", "mps2", "--gyro-unit", "radps"]
N = 400


def _csv(path: Path, rows: dict[int, str] | None = None, time: bool = True) -> Path:
    """A 100 Hz resting CSV (gravity on z); ``rows`` replaces data lines by sample index."""
    lines = ["t,ax,ay,az,gx,gy,gz" if time else "ax,ay,az,gx,gy,gz"]
    for i in range(N):
        vals = f"0.01,-0.02,9.81,0.001,0,0.002"
        lines.append((rows or {}).get(i, f"{i / 100:.2f},{vals}" if time else vals))
    path.write_text("\n".join(lines) + "\n")
    return path


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _err(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return err.strip().splitlines()[-1]


def test_out_equal_to_input_or_a_foreign_file_is_never_overwritten(tmp_path, capsys):
    src = _csv(tmp_path / "walk.csv")
    before = _digest(src)
    assert main(["import", str(src), "--out", str(src), *UNITS]) == 1
    assert "is the input file" in _err(capsys) and _digest(src) == before
    assert main(["import", str(src), "--out", str(src), "--force", *UNITS]) == 1  # not even with --force
    assert _digest(src) == before
    notes = tmp_path / "notes.txt"
    notes.write_text("my field notes\n")
    assert main(["import", str(src), "--out", str(notes), "--force", *UNITS]) == 1
    assert "not an HDF5 file" in _err(capsys) and notes.read_text() == "my field notes\n"


def test_existing_recording_needs_force(tmp_path, capsys):
    src = _csv(tmp_path / "walk.csv")
    out = tmp_path / "walk.h5"
    assert main(["import", str(src), "--out", str(out), "--quiet", *UNITS]) == 0
    first = _digest(out)
    assert main(["import", str(src), "--out", str(out), "--quiet", *UNITS]) == 1
    assert "--force" in _err(capsys) and _digest(out) == first
    assert main(["import", str(src), "--out", str(out), "--quiet", "--force", *UNITS]) == 0
    assert load(out).n == N


def test_a_failing_write_leaves_the_old_recording_and_no_temp_file(tmp_path, monkeypatch):
    """Write-then-rename: an error half-way through the write never touches the existing file."""
    import bootnav.logger.importers.core as core

    src = _csv(tmp_path / "walk.csv")
    out = tmp_path / "walk.h5"
    write_result(read_any(src, acc_unit="mps2", gyro_unit="radps"), out)
    before = _digest(out)

    def broken_group(path, *a, **k):
        raise OSError(28, "No space left on device", str(path))

    result = read_any(src, acc_unit="mps2", gyro_unit="radps")
    result.aux = {"mag": np.zeros(N)}
    monkeypatch.setattr(core, "write_group", broken_group)
    with pytest.raises(DiskFullError, match=f"disk full at {out}: 0 frames written \\(left as it was"):
        write_result(result, out)
    assert _digest(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["walk.csv", "walk.h5"]


@pytest.mark.parametrize("flag, value", [("--rate", "-200"), ("--rate", "nan"), ("--rate", "0"),
                                         ("--acc-range", "-16"), ("--gyro-range", "0")])
def test_impossible_flags_are_refused(tmp_path, capsys, flag, value):
    src = _csv(tmp_path / "notime.csv", time=False)
    out = tmp_path / "x.h5"
    assert main(["import", str(src), "--out", str(out), "--rate", "100", *UNITS, flag, value]) == 1
    assert _err(capsys).startswith(f"bootnav import: error: {flag} ")
    assert not out.exists()


@pytest.mark.parametrize("row, needle", [
    ("0.05,1e30,0,9.81,0,0,0", f"acc of sample 5 (t = 0.05 s) is 1e+30 m/s^2, beyond the physical bound "
                               f"{MAX_ACC_MPS2:g} m/s^2"),
    ("0.05,0,0,9.81,0,0,1e308", f"gyro of sample 5 (t = 0.05 s) is 1e+308 rad/s, beyond the physical bound "
                                f"{MAX_GYRO_RADPS:g} rad/s"),
])
def test_values_beyond_physics_are_refused_with_the_sample(tmp_path, capsys, row, needle):
    src = _csv(tmp_path / "walk.csv", {5: row})
    out = tmp_path / "x.h5"
    assert main(["import", str(src), "--out", str(out), *UNITS]) == 1
    assert needle in _err(capsys)
    assert not out.exists()
    # --no-unit-check keeps the data, with the finding recorded in the file
    assert main(["import", str(src), "--out", str(out), "--no-unit-check", "--quiet", *UNITS]) == 0
    notes = [e["detail"].decode() for e in load(out).events_of("note")]
    assert any("bound check overridden" in d for d in notes)


def test_wrong_time_unit_gives_an_impossible_rate(tmp_path, capsys):
    src = _csv(tmp_path / "walk.csv")  # seconds, read as milliseconds -> 100 kHz
    assert main(["import", str(src), "--out", str(tmp_path / "x.h5"), "--time-unit", "ms", *UNITS]) == 1
    assert "sample rate 1e+05 Hz is outside 1 Hz-10000 Hz; check --time-unit" in _err(capsys)


def test_import_of_a_directory(tmp_path, capsys):
    assert main(["import", str(tmp_path), "--out", str(tmp_path / "x.h5"), *UNITS]) == 1
    assert "is a directory" in _err(capsys)


def test_bounds_hold_on_the_bundled_recordings():
    """The bounds reject nothing real: every bundled recording is inside them."""
    for path in sorted((Path(__file__).resolve().parents[2] / "recordings").glob("*.h5")):
        rec = load(path)
        assert np.nanmax(np.abs(rec.acc_mps2)) <= MAX_ACC_MPS2, path.name
        assert np.nanmax(np.abs(rec.gyro_radps)) <= MAX_GYRO_RADPS, path.name
        with h5py.File(path, "r") as f:
            assert "imu" in f


def test_junk_right_after_the_header_is_a_skipped_line_event(tmp_path):
    src = tmp_path / "walk.csv"
    body = "".join(f"{i / 100:.2f},0.01,-0.02,9.81,0.001,0,0.002\n" for i in range(N))
    src.write_text("t,ax,ay,az,gx,gy,gz\nERROR: I2C timeout\n" + body)
    result = read_any(src, acc_unit="mps2", gyro_unit="radps")
    skipped = [e for e in result.events if e["kind"] == "skipped_line"]
    assert [e["line"] for e in skipped] == [2]
    assert "I2C timeout" in skipped[0]["detail"]
    assert result.n == N  # every data line kept


def test_rad_per_s_walk_imported_as_deg_per_s_is_refused(tmp_path, capsys):
    """The bundled x-io walk (rad/s) declared as deg/s once gave a 7.97 m path instead of 22.85 m."""
    rec = load(Path(__file__).resolve().parents[2] / "recordings" / "xio_ngimu_short_walk.h5")
    src = tmp_path / "walk.csv"
    with open(src, "w") as fh:
        fh.write("t,ax,ay,az,gx,gy,gz\n")
        np.savetxt(fh, np.column_stack([rec.t_s, rec.acc_mps2, rec.gyro_radps]), fmt="%.6f", delimiter=",")
    out = tmp_path / "walk.h5"
    assert main(["import", str(src), "--out", str(out), "--acc-unit", "mps2", "--gyro-unit", "dps"]) == 1
    err = _err(capsys)
    # the file, the declared unit, the evidence (11.2 rad/s peak read as deg/s -> p99 0.188 rad/s) and the fix
    assert err.startswith(f"bootnav import: error: {src}: gyro check failed: while the accelerometer shows motion")
    assert "99th percentile of |rate| is only 0.188 rad/s with the declared unit 'dps'" in err
    assert "use --gyro-unit radps" in err and not out.exists()
    assert main(["import", str(src), "--out", str(out), "--acc-unit", "mps2", "--gyro-unit", "dps",
                 "--trust-units", "--quiet"]) == 0
    assert "overridden: gyro check failed" in load(out).meta["unit_check"]
