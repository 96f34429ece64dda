"""Two boots, one recording (issue 16 point 1), end to end through real pseudo-terminals: a two-boot emulator
process (independent device clocks) -> `bootnav record --port A --port B` -> one multi-boot HDF5 file ->
reopened by fresh processes (bootnav and h5dump). Also `import` of two files and `info` of a multi-boot file.

Alignment bound, from the link: the emulator writes the frames due every ``tick_s`` (5 ms) and a frame is due
up to one period (1 ms at 1 kHz) before it is written, so the newest frame of a read block (the one the clock
fit uses) reaches the host ``L = tick_s + 1/rate`` = 6 ms after it was taken, at most, plus the pty's
sub-millisecond transfer. A latency confined to [0, L] has a standard deviation of at most L/2; host scheduling
stalls that the 3-sigma refit keeps may add as much again, so the fit residual must stay below L. Both boots'
latencies lie in [0, L], so their mean latencies, and hence the relative alignment of the two boots on the
session clock, differ by less than L.
"""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.logger.emulator import EmulatorSettings
from bootnav.logger.recording import boot_labels, load
from tests.conftest import REPO, run_python

pytestmark = pytest.mark.timeout(60)

RATE = 1000.0
L_S = EmulatorSettings(out_link="").tick_s + 1.0 / RATE  # the latency bound of the module docstring


def bootnav(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "bootnav", *args], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def wait_for(*paths: Path, timeout: float = 15.0) -> None:
    end = time.monotonic() + timeout
    while not all(p.is_symlink() for p in paths):
        assert time.monotonic() < end, f"{paths} did not appear"
        time.sleep(0.02)


def finish(proc: subprocess.Popen, timeout: float = 30.0) -> str:
    _, err = proc.communicate(timeout=timeout)
    assert proc.returncode == 0, f"{proc.args} exited {proc.returncode}:\n{err}"
    return err


def two_boot_session(tmp_path: Path, emu_args: list[str], kill_after_s: float | None = None):
    """Two emulated boots recorded together; the recorder is stopped by SIGTERM after the stream, or killed."""
    left, right, out, report = tmp_path / "L", tmp_path / "R", tmp_path / "both.h5", tmp_path / "report.json"
    emu = bootnav("emulate", "--out-link", str(left), "--out-link", str(right), "--rate", str(RATE),
                  "--report", str(report), "--quiet", *emu_args)
    wait_for(left, right)
    rec = bootnav("record", "--port", str(left), "--port", str(right), "--out", str(out), "--quiet")
    if kill_after_s is not None:  # counted from the file's creation (the recorder's start-up varies with load)
        end = time.monotonic() + 20.0
        while not out.exists():
            assert time.monotonic() < end and rec.poll() is None, "the recorder did not create its file"
            time.sleep(0.02)
        time.sleep(kill_after_s)
        rec.kill()  # SIGKILL: no clean-up at all
        rec.communicate()
        t_kill = time.time()
        emu.send_signal(signal.SIGTERM)
        finish(emu)
        return out, json.loads(report.read_text())["boots"], t_kill
    finish(emu)
    time.sleep(0.3)  # the recorder's last read cycle
    rec.send_signal(signal.SIGTERM)
    finish(rec)
    return out, json.loads(report.read_text())["boots"], None


def fresh_load(path: Path) -> dict:
    """Each boot as a new interpreter reads it: seq, t_s, meta and event kinds."""
    code = ("import sys, json\nfrom bootnav.logger.recording import load, boot_labels\n"
            "out = {}\nfor b in boot_labels(sys.argv[1]):\n"
            "    r = load(sys.argv[1], boot=b)\n"
            "    out[b] = {'seq': r.seq.tolist(), 't_s': r.t_s.tolist(), 'attrs': r.attrs,"
            " 'meta': {k: v for k, v in r.meta.items() if isinstance(v, (int, float, str))},"
            " 'kinds': [k.decode() for k in r.events['kind']]}\n"
            "print(json.dumps(out))\n")
    return json.loads(run_python(code, str(path)).stdout)


def alignment_errors(boot: dict, rep: dict) -> np.ndarray:
    """Session time + session start − true emission time of every sample (s): the emulator writes frame k
    of its stream at ``stream_start_unix + k / rate`` (plus its tick) on the host's clock."""
    k = (np.asarray(boot["seq"]) - rep["settings"]["seq0"]) % 65536
    return np.asarray(boot["t_s"]) + boot["attrs"]["session_start_unix_s"] - (rep["stream_start_unix"] + k / RATE)


@pytest.mark.skipif(shutil.which("h5dump") is None, reason="h5dump (hdf5-tools) not installed")
def test_two_boots_on_one_clock_every_valid_frame_kept_corruption_stays_on_its_port(tmp_path):
    # left: 3 % of the frames damaged (bit flips, garbage, drops); right: a clean link. Independent device
    # clocks (-40 / +60 ppm, t0 123456789 µs apart), the right boot starts 0.25 s after the left.
    out, reps, _ = two_boot_session(tmp_path, ["--duration", "4", "--corrupt", "0.03,0", "--seed", "5"])
    boots = fresh_load(out)
    assert list(boots) == ["left", "right"] and boot_labels(out) == ["left", "right"]
    left, right = boots["left"], boots["right"]
    for boot, rep in ((left, reps[0]), (right, reps[1])):
        assert boot["seq"] == rep["valid_seqs"], "every intact frame sent, in order, nothing else"
        assert boot["meta"]["clock_alignment"] == "host-receive"
        assert 0 <= boot["meta"]["clock_residual_s"] < L_S
        assert np.all(np.diff(boot["t_s"]) > 0)
    assert reps[0]["frames_corrupted"] > 20 and reps[0]["frames_dropped"] > 20
    assert left["meta"]["crc_errors"] > 0 and left["meta"]["mount"] == "left_boot"
    assert right["meta"]["crc_errors"] == right["meta"]["dropped"] == 0 and right["meta"]["frames"] == 4000
    assert not {"crc_error", "resync", "gap"} & set(right["kinds"]), "the left port's damage leaked into the right"
    # one session clock: t = 0 at the first sample of any boot, and samples taken at the same moment carry the
    # same t_s to within the latency bound L, although the device clocks started 123 s apart at other rates
    assert min(left["t_s"][0], right["t_s"][0]) == 0.0
    e_left, e_right = alignment_errors(left, reps[0]), alignment_errors(right, reps[1])
    assert abs(np.median(e_left) - np.median(e_right)) < L_S
    assert 0.25 - L_S < right["t_s"][0] - left["t_s"][0] < 0.25 + 0.1  # start delay (+ the two port openings)
    # HDF5 1.10 tools read both boots
    for label, boot in boots.items():
        dump = subprocess.run(["h5dump", "-d", f"/boots/{label}/imu/seq", "-A", "0", "-y", "-w", "0", str(out)],
                              capture_output=True, text=True, timeout=30)
        assert dump.returncode == 0, dump.stderr
        values = dump.stdout.split("DATA {", 1)[1].split("}", 1)[0]
        assert [int(v) for v in values.replace(",", " ").split()] == boot["seq"]
    # info summarises each boot
    info = subprocess.run([sys.executable, "-m", "bootnav", "info", str(out)], cwd=REPO, capture_output=True,
                          text=True, timeout=60)
    assert info.returncode == 0, info.stderr
    assert "boot left" in info.stdout and "boot right" in info.stdout and "host-receive" in info.stdout
    assert "samples     4000 over" in info.stdout
    # a reader that does not say which boot gets a one-line error naming them
    with pytest.raises(InputError, match="left, right"):
        load(out)


def test_kill_9_leaves_both_boots_readable_up_to_the_last_flush(tmp_path):
    out, reps, t_kill = two_boot_session(tmp_path, ["--duration", "10"], kill_after_s=2.5)
    boots = fresh_load(out)
    for boot, rep in zip(boots.values(), reps):
        # flushed every 0.5 s: frames streamed more than 1 s before the kill are all there, contiguous
        due = int((t_kill - 1.0 - rep["stream_start_unix"]) * RATE)
        assert due > 1000 and len(boot["seq"]) >= due  # the file appears once both headers are in (< 0.5 s)
        assert boot["seq"] == rep["valid_seqs"][: len(boot["seq"])]
        assert boot["meta"]["clock_alignment"] == "host-receive-preliminary" and "stop_reason" not in boot["meta"]
    # the preliminary clock (offset of each boot's first read block) is aligned within the latency bound too
    e = [np.median(alignment_errors(b, r)) for b, r in zip(boots.values(), reps)]
    assert abs(e[0] - e[1]) < L_S
    info = subprocess.run([sys.executable, "-m", "bootnav", "info", str(out)], cwd=REPO, capture_output=True,
                          text=True, timeout=60)
    assert info.returncode == 0 and info.stdout.count("no final metadata") == 2, info.stdout + info.stderr


def _csv(path: Path, t0: float, n: int, seed: int) -> np.ndarray:
    """A still boot at 100 Hz with a time column starting at ``t0`` s (acc in m/s², gyro in rad/s)."""
    rng = np.random.default_rng(seed)
    acc = rng.normal(0, 0.02, (n, 3)) + [0.0, 0.0, 9.81]
    gyro = rng.normal(0, 0.01, (n, 3))
    t = t0 + np.arange(n) / 100.0
    rows = np.column_stack([t, acc, gyro])
    path.write_text("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\n"
                    + "\n".join(",".join(f"{v:.6f}" for v in r) for r in rows) + "\n")
    return acc


@pytest.mark.parametrize("rule,args,offsets", [
    ("file-timestamps", [], (0.0, 0.5)),  # default: both time columns on one clock, right starts 0.5 s later
    ("start-together", ["--align", "start"], (0.0, 0.0)),
    ("offset", ["--offset-s", "-0.2"], (0.2, 0.0)),  # right's first sample 0.2 s before left's
])
def test_import_two_files_into_one_multi_boot_recording(tmp_path, rule, args, offsets):
    acc_l = _csv(tmp_path / "left.csv", 100.0, 300, 1)
    acc_r = _csv(tmp_path / "right.csv", 100.5, 250, 2)
    out = tmp_path / "both.h5"
    res = subprocess.run([sys.executable, "-m", "bootnav", "import", str(tmp_path / "left.csv"),
                          str(tmp_path / "right.csv"), "--labels", "left,right", "--out", str(out), *args],
                         cwd=REPO, capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    assert boot_labels(out) == ["left", "right"]
    for label, acc, n, off in (("left", acc_l, 300, offsets[0]), ("right", acc_r, 250, offsets[1])):
        r = load(out, boot=label)
        assert r.meta["clock_alignment"] == rule and r.meta["mount"] == f"{label}_boot"
        np.testing.assert_allclose(r.t_s, off + np.arange(n) / 100.0, atol=1e-9)
        np.testing.assert_allclose(r.acc_mps2, np.round(acc, 6), atol=1e-9)
    again = subprocess.run([sys.executable, "-m", "bootnav", "import", str(tmp_path / "left.csv"),
                            str(tmp_path / "right.csv"), "--out", str(out)], cwd=REPO, capture_output=True,
                           text=True, timeout=60)
    assert again.returncode != 0 and "--force" in again.stderr and len(again.stderr.strip().splitlines()) == 1


def test_clock_fit_recovers_rate_and_per_restart_offsets_despite_stalls():
    from bootnav.logger.serial_recorder import fit_host_clock

    rng = np.random.default_rng(11)
    n, scale, offsets = 3000, 1 + 80e-6, np.array([2.0, 2.7])  # host s per device s; a device restart at 1800
    dev = np.sort(rng.uniform(0, 60, n))
    seg = (np.arange(n) >= 1800).astype(int)
    latency = rng.uniform(0, L_S, n)
    latency[rng.choice(n, 15, replace=False)] += 0.2  # scheduling stalls: rejected by the refit
    host = offsets[seg] + scale * dev + latency
    off, sc, resid, used = fit_host_clock(dev, host, 3.0, seg)
    sigma = L_S / np.sqrt(12)  # std of a uniform latency on [0, L]
    assert used == n - 15 and abs(resid - sigma) < 0.1 * sigma
    assert abs(sc - scale) < 5 * sigma / (60 * np.sqrt(n / 12))  # slope error of a least-squares line
    np.testing.assert_allclose(off - offsets, L_S / 2, atol=5 * sigma / np.sqrt(1200))  # + the mean latency
