"""``bootnav info``: summaries computed from the data and events, for recorded, imported and crashed files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bootnav.logger.recording import make_events, si_channel, write_recording
from tests.conftest import REPO, run_python
from tests.test_serial_record import emulate_and_record

pytestmark = pytest.mark.timeout(60)


def info_json(path) -> dict:
    """Run the real command in a fresh process."""
    proc = run_python("import sys; from bootnav.cli import main; sys.exit(main(sys.argv[1:]))",
                      "info", str(path), "--json")
    return json.loads(proc.stdout)


def test_info_agrees_with_what_the_emulator_sent(tmp_path):
    out, report, _ = emulate_and_record(
        tmp_path, ["--duration", "1.5", "--rate", "500", "--corrupt", "0.04", "--seed", "5"])
    s = info_json(out)
    assert s["frames"] == len(report["valid_seqs"])
    assert s["dropped"] == report["frames_dropped"] + report["frames_corrupted"]
    assert s["crc_errors"] >= 1 and s["resyncs"] >= report["garbage_bursts"]
    assert s["rate_hz"] == pytest.approx(500.0, rel=1e-9)
    # first..last valid frame on the device clock
    first, last = report["valid_index"][0], report["valid_index"][-1]
    assert s["duration_s"] == pytest.approx((last - first) / 500.0, abs=1e-9)
    assert s["accel_range_g"] == 16 and s["gyro_range_dps"] == 2000 and s["complete"]


def test_info_on_an_imported_style_si_file_finds_gaps_from_timestamps_and_saturation(tmp_path):
    rate = 100.0
    t = np.arange(1000) / rate
    t = np.delete(t, np.r_[300:305])  # 5 samples missing, no seq numbers
    n = t.size
    sat = np.zeros(n, np.uint8)
    sat[50:53] = 1 << 4  # gy at full scale for 3 samples
    path = tmp_path / "imported.h5"
    write_recording(path, t, np.zeros((n, 3)), np.zeros((n, 3)), saturated=sat,
                    acc_channel=si_channel("acc", 16 * 9.80665), gyro_channel=si_channel("gyro", np.deg2rad(250)),
                    events=make_events([{"kind": "skipped_line", "line": 17, "detail": "bad number"}]))
    s = info_json(path)
    assert s["frames"] == n and s["gaps"] == 1 and s["dropped"] == 5 and s["gap_source"] == "timestamps"
    assert s["saturated_samples"]["gy"] == 3 and s["saturated_any"] == 3
    assert s["accel_range_g"] == pytest.approx(16) and s["gyro_range_dps"] == pytest.approx(250)
    assert s["skipped_lines"] == 1 and s["rate_hz"] == pytest.approx(rate)


def test_info_on_a_file_whose_writer_died(tmp_path):
    path = tmp_path / "crashed.h5"
    code = (
        "import os, sys, numpy as np\n"
        "from bootnav.logger.recording import RecordingWriter, counts_channel\n"
        "w = RecordingWriter(sys.argv[1], counts_channel('acc', 1e-3), counts_channel('gyro', 1e-3), seq=True)\n"
        "w.append(np.arange(300) / 200.0, np.zeros((300, 3), np.int16), np.zeros((300, 3), np.int16),"
        " seq=np.arange(300, dtype=np.uint16))\n"
        "w.flush()\n"
        "os._exit(0)\n"  # no close(): SWMR flags stay set, no final metadata
    )
    run_python(code, str(path))
    s = info_json(path)
    assert s["frames"] == 300 and not s["complete"] and s["rate_hz"] == pytest.approx(200.0)
    text = run_python("import sys; from bootnav.cli import main; sys.exit(main(sys.argv[1:]))", "info", str(path)).stdout
    assert "did not close" in text and "300" in text


def test_info_on_a_non_recording_is_a_clear_error(tmp_path):
    bad = tmp_path / "not.h5"
    bad.write_bytes(b"this is not hdf5")
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "bootnav", "info", str(bad)], capture_output=True, text=True,
                          cwd=REPO, timeout=60)
    assert proc.returncode == 1 and "not.h5" in proc.stderr and "cannot open" in proc.stderr


def test_one_gap_rule_for_importer_info_and_filter(tmp_path):
    """A step of 1.4 periods is jitter, 1.6 periods one lost sample, 3.2 periods two: the importer's events,
    ``bootnav info`` on timestamps alone and the filter's time base all say so."""
    from bootnav.core.timebase import time_base
    from bootnav.logger.cli_info import summarize
    from bootnav.logger.importers import read_any

    dt = np.full(400, 0.01)
    dt[[100, 200, 300]] = [0.014, 0.016, 0.032]
    t = np.round(np.r_[0.0, np.cumsum(dt)], 4)
    src = tmp_path / "g.csv"
    src.write_text("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\n"
                   + "\n".join(f"{x:.4f},0,0,9.80665,0,0,0" for x in t) + "\n")
    gaps = [(e["sample_index"], e["count"]) for e in read_any(src).events if e["kind"] == "gap"]
    assert gaps == [(201, 1), (301, 2)]
    path = tmp_path / "no_events.h5"  # no gap events stored: info falls back to the timestamps
    write_recording(path, t, np.zeros((t.size, 3)), np.zeros((t.size, 3)), acc_channel=si_channel("acc", np.nan),
                    gyro_channel=si_channel("gyro", np.nan))
    s = summarize(path)
    assert s["gap_source"] == "timestamps"
    assert [(g["sample_index"], g["missing"]) for g in s["gap_list"]] == gaps
    assert [i for i, _ in time_base(t).gaps] == [201, 301]


def test_info_shows_the_hole_and_the_reconnect_of_a_device_that_rebooted(tmp_path):
    """``--restart-on-reconnect``: seq and t_us restart from 0, so no seq gap; the hole is in the time stamps."""
    from bootnav.logger.recording import load

    out, report, _ = emulate_and_record(
        tmp_path, ["--duration", "2.0", "--rate", "500", "--disconnect-at", "0.6", "--disconnect-pause", "1.0",
                   "--restart-on-reconnect"])
    rec = load(out)
    k = int(np.flatnonzero(np.diff(rec.seq.astype(int)) != 1)[0]) + 1  # first frame after the reboot
    hole_s = rec.t_s[k] - rec.t_s[k - 1]
    assert hole_s > 1.0  # the port was away 1 s
    s = info_json(out)
    assert s["disconnects"] >= 1 and s["reconnects"] == 1
    assert s["gaps"] == 1 and s["gap_list"][0]["sample_index"] == k
    assert s["dropped"] == round(hole_s * 500) - 1  # the samples that fit into the hole at 500 Hz
    assert "device restart" in s["gap_source"]
    text = run_python("import sys; from bootnav.cli import main; sys.exit(main(sys.argv[1:]))", "info", str(out)).stdout
    assert f"gaps        1 ({s['dropped']} samples missing" in text and ", 1 reconnects," in text
