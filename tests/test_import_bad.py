"""Bad inputs: a clear error that says what and where, or a documented recovery that loses no good line."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.logger.importers import import_file, read_any
from bootnav.logger.recording import load
from tests.conftest import reopen_in_fresh_process

G = 9.80665
HEADER = "t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps"


def walk_rows(n=600, rate=100.0, seed=0, acc_scale=1.0, gyro_scale=1.0):
    """A made-up foot signal: 2 s at rest, then 1 Hz strides; acc in m/s^2, gyro in rad/s."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    moving = t > 2.0
    acc = np.zeros((n, 3))
    acc[:, 2] = G
    acc[:, 0] += 15 * np.sin(2 * np.pi * t) * moving
    gyro = np.zeros((n, 3))
    gyro[:, 1] = 6.0 * np.sin(2 * np.pi * t) * moving  # ~340 deg/s peak: a brisk walk
    acc += rng.normal(0, 0.02, acc.shape)
    gyro += rng.normal(0, 0.005, gyro.shape)
    return t, acc * acc_scale, gyro * gyro_scale


def write_csv(path, t, acc, gyro, header=HEADER, fmt="{:.6f}", delim=",", end="\n"):
    lines = [header] if header else []
    for i in range(t.size):
        lines.append(delim.join(fmt.format(v) for v in (t[i], *acc[i], *gyro[i])))
    path.write_text(end.join(lines) + end)
    return lines


def test_empty_file(tmp_path):
    (tmp_path / "e.csv").write_text("")
    with pytest.raises(InputError, match="e.csv: file is empty"):
        read_any(tmp_path / "e.csv")
    (tmp_path / "b.csv").write_text("\n\n  \n# only a comment\n")
    with pytest.raises(InputError, match="no data lines"):
        read_any(tmp_path / "b.csv")


def test_binary_garbage(tmp_path):
    (tmp_path / "g.csv").write_bytes(np.random.default_rng(3).integers(0, 256, 5000, dtype=np.uint8).tobytes())
    with pytest.raises(InputError, match="binary file.*offset"):
        read_any(tmp_path / "g.csv")


def test_truncated_last_line_kept_everything_before(tmp_path):
    t, a, g = walk_rows()
    lines = write_csv(tmp_path / "x.csv", t, a, g)
    text = (tmp_path / "x.csv").read_text()
    (tmp_path / "x.csv").write_text(text + lines[-1][:9])  # power loss mid-line, no newline
    out = import_file(tmp_path / "x.csv", tmp_path / "x.h5")
    rec = load(out)
    assert rec.n == t.size
    sk = rec.events_of("skipped_line")
    assert list(sk["line"]) == [t.size + 2] and b"truncated" in sk["detail"][0]
    assert reopen_in_fresh_process(out)["n"] == t.size


def test_malformed_and_nan_lines_skipped_with_line_numbers(tmp_path):
    t, a, g = walk_rows()
    lines = write_csv(tmp_path / "x.csv", t, a, g)
    lines[11] = "ERROR: I2C timeout"  # line 12
    lines[51] = lines[51].replace(lines[51].split(",")[2], "nan", 1)  # line 52: NaN in ay
    lines[101] = ",".join(lines[101].split(",")[:5])  # line 102: too few fields
    (tmp_path / "x.csv").write_text("\n".join(lines) + "\n")
    r = read_any(tmp_path / "x.csv")
    assert r.n == t.size - 3  # every good line kept
    sk = sorted((e["line"], e["detail"]) for e in r.events if e["kind"] == "skipped_line")
    assert [ln for ln, _ in sk] == [12, 52, 102]
    assert "NaN" in sk[1][1] and "fields" in sk[2][1]
    assert any("x.csv:52" in m for m in r.messages)
    assert not np.isnan(r.acc).any()


def test_mostly_garbage_is_an_error(tmp_path):
    t, a, g = walk_rows(100)
    lines = write_csv(tmp_path / "x.csv", t, a, g)
    lines[1:80] = ["1,2,three,4,5,6,7"] * 79
    (tmp_path / "x.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match="79 of 100 data lines are malformed.*line 2"):
        read_any(tmp_path / "x.csv")


def test_nonmonotonic_and_duplicate_time_kept_as_events(tmp_path):
    t, a, g = walk_rows()
    t = t.copy()
    t[300] = t[299]  # duplicate
    t[400] = t[398]  # goes back
    write_csv(tmp_path / "x.csv", t, a, g)
    r = read_any(tmp_path / "x.csv")
    assert r.n == t.size and np.allclose(r.t_s, t - t[0])  # kept, not reordered or resampled
    dup = [e for e in r.events if e["kind"] == "duplicate_time"]
    back = [e for e in r.events if e["kind"] == "nonmonotonic_time"]
    assert [e["sample_index"] for e in dup] == [300] and [e["line"] for e in dup] == [302]
    assert [e["sample_index"] for e in back] == [400] and [e["line"] for e in back] == [402]


def test_u32_microsecond_wrap_in_generic_csv(tmp_path):
    t, a, g = walk_rows()
    t_us = (2**32 - 250 * 10_000 + np.arange(t.size) * 10_000) % 2**32  # wraps at sample 250
    write_csv(tmp_path / "x.csv", t_us.astype(float), a, g, header="t_us,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps",
              fmt="{:.0f}")
    r = read_any(tmp_path / "x.csv")
    assert r.meta["time_unit_source_file"] == "us"
    assert np.allclose(np.diff(r.t_s), 0.01)
    wraps = [e for e in r.events if e["kind"] == "time_wrap"]
    assert [e["sample_index"] for e in wraps] == [250] and [e["line"] for e in wraps] == [252]
    assert r.count("nonmonotonic_time") == 0


@pytest.mark.parametrize("declared,actual_scale,hint", [
    ("mps2", 1 / G, "--acc-unit g"),  # data in g declared as m/s^2
    ("g", 1.0, "--acc-unit mps2"),  # m/s^2 declared as g
])
def test_wrong_acc_unit(tmp_path, declared, actual_scale, hint):
    t, a, g = walk_rows(acc_scale=actual_scale)
    write_csv(tmp_path / "x.csv", t, a, g, header="t,ax,ay,az,gx,gy,gz")
    with pytest.raises(InputError, match=f"gravity check failed.*{hint}"):
        read_any(tmp_path / "x.csv", acc_unit=declared, gyro_unit="radps")
    r = read_any(tmp_path / "x.csv", acc_unit=declared, gyro_unit="radps", check_units=False)
    assert any("unit check overridden" in e["detail"] for e in r.events)


def test_wrong_counts_range(tmp_path):
    t, a, g = walk_rows()
    acc_counts = np.round(a / G * 16384).clip(-32768, 32767)  # +-2 g counts
    gyro_counts = np.round(np.degrees(g) * 131).clip(-32768, 32767)
    write_csv(tmp_path / "x.csv", t * 1000, acc_counts, gyro_counts, header=None, fmt="{:.0f}")
    with pytest.raises(InputError, match="--acc-unit counts --acc-range 2"):
        read_any(tmp_path / "x.csv", acc_unit="counts", gyro_unit="counts", acc_range_g=16, gyro_range_dps=250,
                 time_unit="ms")
    r = read_any(tmp_path / "x.csv", acc_unit="counts", gyro_unit="counts", acc_range_g=2, gyro_range_dps=250,
                 time_unit="ms")
    assert r.acc.dtype == np.int16 and r.acc_mps2[:200, 2].mean() == pytest.approx(G, rel=0.01)


def test_deg_per_s_declared_as_rad_per_s(tmp_path):
    t, a, g = walk_rows()
    write_csv(tmp_path / "x.csv", t, a, np.degrees(g), header="t,ax,ay,az,gx,gy,gz")
    with pytest.raises(InputError, match="gyro check failed.*--gyro-unit dps"):
        read_any(tmp_path / "x.csv", acc_unit="mps2", gyro_unit="radps")
    r = read_any(tmp_path / "x.csv", acc_unit="mps2", gyro_unit="dps")
    assert np.abs(r.gyro_radps[:, 1]).max() == pytest.approx(6.0, rel=0.02)


def test_missing_information_is_asked_for(tmp_path):
    t, a, g = walk_rows(200)
    (tmp_path / "six.csv").write_text("\n".join(",".join(f"{v:.5f}" for v in (*a[i], *g[i])) for i in range(200)))
    with pytest.raises(InputError, match="--rate"):
        read_any(tmp_path / "six.csv")
    r = read_any(tmp_path / "six.csv", rate_hz=100, acc_unit="mps2", gyro_unit="radps")
    assert r.t_s[-1] == pytest.approx(1.99)
    write_csv(tmp_path / "nounit.csv", t, a, g, header="t,ax,ay,az,gx,gy,gz")
    with pytest.raises(InputError, match="--gyro-unit"):
        read_any(tmp_path / "nounit.csv")
    with pytest.raises(InputError, match="unknown profile 'nope'.*xio_ngimu_csv"):
        read_any(tmp_path / "nounit.csv", profile="nope")
    with pytest.raises(InputError, match="no such file"):
        read_any(tmp_path / "missing.csv")


def test_cli_error_is_one_clear_line(tmp_path):
    import subprocess
    import sys

    from tests.conftest import REPO

    t, a, g = walk_rows()
    write_csv(tmp_path / "x.csv", t, a / G, g, header="t,ax,ay,az,gx,gy,gz")
    proc = subprocess.run([sys.executable, "-m", "bootnav", "import", str(tmp_path / "x.csv"), "--acc-unit", "mps2",
                           "--gyro-unit", "radps", "--out", str(tmp_path / "x.h5")], capture_output=True, text=True,
                          cwd=REPO, timeout=60)
    assert proc.returncode == 1
    assert "x.csv: gravity check failed" in proc.stderr and "--acc-unit g" in proc.stderr
    assert not (tmp_path / "x.h5").exists()


def test_rad_per_s_declared_as_deg_per_s_is_an_error(tmp_path):
    t, a, g = walk_rows()
    write_csv(tmp_path / "x.csv", t, a, g, header="t,ax,ay,az,gx,gy,gz")  # rad/s, peak 6 rad/s
    # read as deg/s the 6 rad/s swing peaks at 0.105 rad/s: below the 0.3 rad/s no walking foot stays under
    with pytest.raises(InputError, match=r"x.csv: gyro check failed: .* only 0.1\d* rad/s with the declared unit "
                                         r"'dps'.*use --gyro-unit radps"):
        read_any(tmp_path / "x.csv", acc_unit="mps2", gyro_unit="dps")
    r = read_any(tmp_path / "x.csv", acc_unit="mps2", gyro_unit="dps", check_units=False)
    assert "overridden: gyro check failed" in r.meta["unit_check"]
    r = read_any(tmp_path / "x.csv", acc_unit="mps2", gyro_unit="radps")
    assert "unit_check" not in r.meta and not any("gyro" in e["detail"] for e in r.events if e["kind"] == "note")


def test_borderline_units_are_warned_and_recorded(tmp_path):
    """A gyro between 0.3 and 0.6 rad/s in deg/s, |acc| at rest 10-25 % off g: kept, with a warning in /meta."""
    t, a, g = walk_rows()
    write_csv(tmp_path / "x.csv", t, a * 1.15, np.degrees(g) * 0.4 / 6.0, header="t,ax,ay,az,gx,gy,gz")
    r = read_any(tmp_path / "x.csv", acc_unit="mps2", gyro_unit="dps")
    assert r.meta["unit_check"].startswith("gravity borderline: at rest")
    assert "+15 % off g" in r.meta["unit_check"] and "gyro suspiciously small" in r.meta["unit_check"]
    assert sum("suspiciously small" in e["detail"] for e in r.events) == 1
    # the same gyro at 1 rad/s peak, gravity right: nothing to say
    write_csv(tmp_path / "y.csv", t, a, np.degrees(g) / 6.0, header="t,ax,ay,az,gx,gy,gz")
    assert "unit_check" not in read_any(tmp_path / "y.csv", acc_unit="mps2", gyro_unit="dps").meta


def test_cp1252_header_with_degree_sign(tmp_path):
    t, a, g = walk_rows(300)
    lines = ["time (s);acc x (m/s²);acc y (m/s²);acc z (m/s²);gyro x (°/s);gyro y (°/s);gyro z (°/s)"]
    lines += [";".join(f"{v:.5f}".replace(".", ",") for v in (t[i], *a[i], *np.degrees(g[i]))) for i in range(300)]
    (tmp_path / "w.csv").write_bytes("\r\n".join(lines).encode("cp1252"))
    r = read_any(tmp_path / "w.csv")
    assert r.meta["gyro_unit_source_file"] == "dps" and r.meta["acc_unit_source_file"] == "mps2"
    np.testing.assert_allclose(r.gyro_radps, np.round(np.degrees(g), 5) * math.pi / 180, atol=1e-9)


def test_time_of_day_text_column(tmp_path):
    t, a, g = walk_rows(300)
    stamps = [f"17:23:{55 + int(x // 1):02d}:{int(round((x % 1) * 1000)):03d}" for x in t]
    lines = ["time,ax (m/s^2),ay (m/s^2),az (m/s^2),wx (rad/s),wy (rad/s),wz (rad/s)"]
    lines += [stamps[i] + "," + ",".join(f"{v:.5f}" for v in (*a[i], *g[i])) for i in range(300)]
    (tmp_path / "tod.csv").write_text("\n".join(lines) + "\n")
    r = read_any(tmp_path / "tod.csv")
    assert r.meta["time_source"] == "time_of_day"
    np.testing.assert_allclose(r.t_s, t, atol=1e-6)


@pytest.mark.parametrize("header", [HEADER, "time,ax,ay,az,gx,gy,gz"])  # canonical reader / generic parser
def test_cut_off_gzip_keeps_every_complete_line_and_reports_the_cut(tmp_path, header):
    import gzip

    t, a, g = walk_rows(3000)
    lines = write_csv(tmp_path / "x.csv", t, a, g, header=header)
    z = gzip.compress((tmp_path / "x.csv").read_bytes())
    src = tmp_path / "x.csv.gz"
    src.write_bytes(z[: int(len(z) * 0.6)])  # an interrupted copy
    kw = {} if header == HEADER else dict(acc_unit="mps2", gyro_unit="radps", time_unit="s")
    r = read_any(src, **kw)
    n = r.n
    assert 1000 < n < 3000
    assert np.array_equal(r.t_s, np.array([float(ln.split(",")[0]) for ln in lines[1 : n + 1]]))
    skipped = [e for e in r.events if e["kind"] == "skipped_line"]
    assert [e["line"] for e in skipped] == [n + 2] and "cut off" in skipped[0]["detail"]  # header = line 1
    assert any(e["kind"] == "note" and "cut off" in e["detail"] for e in r.events)
