"""Generic CSV/TXT, phone formats (synthetic samples in tests/data/), user profiles, the canonical dataset
files (every one, no options, checked against manifest.json), and the import speed."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from bootnav.logger.importers import builtin_names, import_file, load_aux, read_any, write_result
from bootnav.logger.importers.text import parse_table, read_text
from bootnav.logger.recording import load
from tests.conftest import REPO, reopen_in_fresh_process

DATA = Path(__file__).parent / "data"
G = 9.80665


def sample_rows(n=300, seed=0):
    rng = np.random.default_rng(seed)
    t = np.round(np.arange(n) / 100.0, 4)
    acc = np.round(rng.normal(0, 0.3, (n, 3)) + [0.1, -0.2, G], 4)
    gyro = np.round(rng.normal(0, 0.2, (n, 3)), 4)
    return np.column_stack([t, acc, gyro])


VARIANTS = {
    "comma_lf": dict(delim=",", end="\n", header="t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps"),
    "crlf_trailing_comma": dict(delim=",", end="\r\n", header="t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps,",
                                trailing=True),
    "semicolon_decimal_comma": dict(delim=";", end="\n", header="t (s);ax (m/s^2);ay (m/s^2);az (m/s^2);"
                                    "gx (rad/s);gy (rad/s);gz (rad/s)", comma=True),
    "tab_quoted_header": dict(delim="\t", end="\n", header='"Time (s)"\t"Acc X (m/s^2)"\t"Acc Y (m/s^2)"\t'
                              '"Acc Z (m/s^2)"\t"Gyro X (rad/s)"\t"Gyro Y (rad/s)"\t"Gyro Z (rad/s)"'),
    "whitespace_comments_blank_lines": dict(delim="   ", end="\n", header="# logger v2, 100 Hz\n\n"
                                            "time_s ax_mps2 ay_mps2 az_mps2 gx_radps gy_radps gz_radps", blank=True),
    "headerless_seed004_default_order": dict(delim=",", end="\n", header=None),
    "comma_quoted_decimal_comma": dict(delim=",", end="\n", header='"time","ax (m/s^2)","ay (m/s^2)","az (m/s^2)",'
                                       '"wx (rad/s)","wy (rad/s)","wz (rad/s)"', comma=True, quote=True),
}


@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_delimiters_headers_line_ends_give_identical_numbers(tmp_path, variant):
    v = VARIANTS[variant]
    ref = sample_rows()
    lines = [v["header"]] if v["header"] else []
    for k, row in enumerate(ref):
        cells = [f"{x:.4f}".replace(".", ",") if v.get("comma") else f"{x:.4f}" for x in row]
        cells = [f'"{c}"' for c in cells] if v.get("quote") else cells
        lines.append(v["delim"].join(cells) + (v["delim"] if v.get("trailing") else ""))
        if v.get("blank") and k % 10 == 0:
            lines.append("")
    path = tmp_path / f"{variant}.txt"
    path.write_bytes(v["end"].join(lines).encode() + v["end"].encode())
    overrides = dict(acc_unit="mps2", gyro_unit="radps") if v["header"] is None else {}
    if v.get("quote"):
        overrides["time_unit"] = "s"
    r = read_any(path, **overrides)
    np.testing.assert_allclose(r.t_s, ref[:, 0] - ref[0, 0], atol=1e-12)
    np.testing.assert_allclose(r.acc_mps2, ref[:, 1:4], rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.gyro_radps, ref[:, 4:7], rtol=0, atol=1e-12)
    assert r.count("skipped_line") == 0


def test_columns_option_and_user_profile(tmp_path):
    ref = sample_rows()
    # gyro first, degrees, time in ms, an extra column to ignore
    lines = [f"{r[0] * 1000:.1f} {np.degrees(r[4]):.5f} {np.degrees(r[5]):.5f} {np.degrees(r[6]):.5f} "
             f"{r[1] / G:.7f} {r[2] / G:.7f} {r[3] / G:.7f} 42" for r in ref]
    (tmp_path / "odd.txt").write_text("\n".join(lines) + "\n")
    r = read_any(tmp_path / "odd.txt", columns="t,gx,gy,gz,ax,ay,az,-", time_unit="ms", acc_unit="g", gyro_unit="dps")
    np.testing.assert_allclose(r.acc_mps2, ref[:, 1:4], atol=1e-5)
    np.testing.assert_allclose(r.gyro_radps, ref[:, 4:7], atol=1e-6)
    prof = tmp_path / "mine.toml"
    prof.write_text('name = "mine"\ncolumns = ["t","gx","gy","gz","ax","ay","az","aux:flag"]\ntime_unit = "ms"\n'
                    'acc_unit = "g"\ngyro_unit = "dps"\nmount = "left_boot"\n')
    out = import_file(tmp_path / "odd.txt", tmp_path / "odd.h5", profile=prof)
    rec = load(out)
    assert rec.meta["importer_profile"] == "mine" and rec.meta["mount"] == "left_boot"
    np.testing.assert_allclose(rec.acc_mps2, ref[:, 1:4], atol=1e-5)
    assert np.all(load_aux(out)["flag"] == 42)


def test_physics_toolbox_android_semicolon_decimal_comma():
    src = DATA / "physics_toolbox_android_synthetic.csv"  # SYNTHETIC sample (tests/data/make_synthetic.py)
    lines = src.read_text().splitlines()
    ref = np.array([[float(x.replace(",", ".")) for x in ln.split(";")] for ln in lines[1:]])
    r = read_any(src)
    assert r.profile == "physics_toolbox_csv"
    np.testing.assert_allclose(r.acc_mps2, ref[:, 1:4] * G)  # gF in g
    np.testing.assert_allclose(r.gyro_radps, ref[:, 4:7])  # w in rad/s
    repeated = int(np.sum(np.all(ref[1:, 1:7] == ref[:-1, 1:7], axis=1)))
    assert repeated > 100
    assert any(e["kind"] == "note" and e["count"] == repeated for e in r.events)


def test_physics_toolbox_ios_datetime_and_repeated_rows():
    src = DATA / "physics_toolbox_ios_synthetic.csv"  # SYNTHETIC, CRLF, date-time text time column
    r = read_any(src)
    assert r.profile == "physics_toolbox_csv" and r.meta["gyro_present"] == 0
    assert r.n == 612  # 600 samples + 12 exact repeats, all kept
    assert r.count("duplicate_time") == 12
    assert r.meta["start_utc"].startswith("2018-10-03T17:23:55.464")
    assert np.median(np.diff(r.t_s)[np.diff(r.t_s) > 0]) == pytest.approx(0.01, abs=1e-6)


@pytest.mark.parametrize("name", ["phyphox_acc_comma_synthetic.csv", "phyphox_acc_semicolon_decimal_comma_synthetic.csv"])
def test_phyphox_acceleration_with_g(name, tmp_path):
    src = DATA / name  # SYNTHETIC phyphox exports
    out = import_file(src, tmp_path / "p.h5")
    rec = load(out)
    assert rec.meta["importer_profile"] == "phyphox_csv" and rec.n == 800
    assert rec.meta["acc_quantity"] == "specific_force"
    assert np.median(np.linalg.norm(rec.acc_mps2[:150], axis=1)) == pytest.approx(G, rel=0.01)
    assert rec.meta["t0_source_s"] == pytest.approx(-0.0021)
    assert reopen_in_fresh_process(out)["n"] == 800  # NaN gyro loads fine in a fresh process


def test_waist20_seed000_log():
    src = DATA / "waist20_seed000_synthetic.txt"  # SYNTHETIC: seed-000 gives no file layout
    r = read_any(src)
    assert r.profile == "waist20_seed000"
    assert r.meta["rate_measured_hz"] == pytest.approx(20.0, rel=0.01)
    assert r.meta["t0_source_s"] == pytest.approx(5123.450)
    assert np.all(np.isnan(r.gyro))
    assert 0 <= r.aux["heading_deg"].min() and r.aux["heading_deg"].max() < 360


def test_every_profile_is_valid_toml_with_description():
    names = builtin_names()
    for required in ("iez_mpu6050_csv", "ttruty_sd_log", "sstk123_mpu9250_serial", "purestreams_phyphox",
                     "koroglu_sensorconnect_csv", "xio_ngimu_csv", "openshoe_820_txt", "physics_toolbox_csv",
                     "phyphox_csv", "waist20_seed000", "canonical_imu_csv", "canonical_acc_csv"):
        assert required in names
    from bootnav.logger.importers import load_profile

    assert all(load_profile(n).get("description") for n in names)


def test_every_canonical_dataset_file_imports_without_options(datasets):
    """All imu*.csv.gz and acc.csv.gz: sample count, duplicate and backward times exactly as manifest.json."""
    manifest = json.loads((datasets / "manifest.json").read_text())
    expected = {datasets / tr["path"] / f: c for tr in manifest["trials"] for f, c in tr["checks"].items()}
    files = sorted(datasets.rglob("imu*.csv.gz")) + sorted(datasets.rglob("acc.csv.gz"))
    assert len(files) >= 100
    kinds = set()
    for f in files:
        r = read_any(f)
        kinds.add(r.profile)
        c = expected[f]
        assert (r.n, r.count("duplicate_time"), r.count("nonmonotonic_time")) == (
            c["n"], c["n_duplicate_t"], c["n_backwards_t"]), f
        if r.profile == "canonical_acc_csv":
            assert r.meta["gyro_present"] == 0 and np.all(np.isnan(r.gyro))
    assert kinds == {"canonical_imu_csv", "canonical_acc_csv"}


def test_canonical_acc_only_reopens_in_fresh_process(datasets, tmp_path):
    src = sorted(datasets.rglob("acc.csv.gz"))[0]
    out = import_file(src, tmp_path / "acc.h5")
    fresh = reopen_in_fresh_process(out)
    assert fresh["n"] == load(out).n and fresh["meta"]["gyro_present"] == "0"


def test_cli_autodetects_and_prints(datasets, tmp_path):
    src = datasets / "raw-formats" / "ttruty_sd_log" / "Steps21.txt"
    proc = subprocess.run([sys.executable, "-m", "bootnav", "import", str(src), "--out", str(tmp_path / "t.h5"),
                           "--mount", "right_ankle"], capture_output=True, text=True, cwd=REPO, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert "profile: ttruty_sd_log (auto-detected)" in proc.stdout and "1-s RTC" in proc.stdout
    assert load(tmp_path / "t.h5").meta["mount"] == "right_ankle"


def test_one_hour_at_200_hz_takes_seconds(tmp_path):
    """720 000 rows x 7 columns: the numpy fast path (no per-line Python) must take it."""
    n = 720_000
    rng = np.random.default_rng(7)
    block = np.column_stack([rng.normal(0, 0.5, (1000, 3)) + [0, 0, G], rng.normal(0, 1, (1000, 3))])
    cells = [",".join(f"{v:.5f}" for v in row) for row in block]  # 1000 distinct rows, cycled
    src = tmp_path / "hour.csv"
    rows = [f"{k * 0.005:.3f},{cells[k % 1000]}" for k in range(n)]
    rows[100_000] = "E: SD write error"  # line 100 002
    rows[500_000] = rows[500_000][:12]  # line 500 002, a torn line
    src.write_text("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\n" + "\n".join(rows) + "\n")
    text, _, _ = read_text(src)
    assert parse_table(src, text).matrix is not None  # numpy path (per chunk), no per-line Python over the file
    t0 = time.perf_counter()
    r = read_any(src)
    out = write_result(r, tmp_path / "hour.h5")
    dt = time.perf_counter() - t0
    print(f"\nimport of 1 h at 200 Hz (720k rows, {src.stat().st_size / 1e6:.0f} MB, 2 bad lines): {dt:.2f} s")
    assert sorted(e["line"] for e in r.events if e["kind"] == "skipped_line") == [100_002, 500_002]
    assert load(out).n == n - 2
    assert dt < 30  # seconds, not minutes, even on a loaded 2-core CI box (about 3 s when idle)
