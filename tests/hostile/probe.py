"""Hostile-input probe (issue 27): re-run every class of the issue and print one row per case.

``python tests/hostile/probe.py [--only SUBSTR] [--keep DIR]`` builds its fixtures in a temporary folder, runs each
case as a user would (a fresh ``bootnav`` process, or a fresh Python for the API cases) and prints

    case | exit code | first line of stderr | verdict

where the verdict is ``ok`` or says what went wrong: an input whose SHA-256 changed (a destroyed file), a hang
(the case's time limit passed), a traceback, a segfault, an "unexpected ..." message, or the case's own check
(e.g. an output that should have been refused exists). The last line counts them, so a re-run can be quoted as
"no destroyed file, no hang, no traceback, no unexpected".

The tests of ``tests/hostile/`` import the fixture builders and the runner from here (one definition).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import resource
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

REPO = Path(__file__).resolve().parents[2]
RECORDINGS = REPO / "recordings"
G = 9.80665


def bootnav_cmd() -> list[str]:
    return [sys.executable, "-m", "bootnav"]


def sha256(path: Path) -> str:
    p = Path(path)
    if not p.exists() and not p.is_symlink():
        return "missing"
    if p.is_symlink() and not p.exists():
        return "dangling->" + os.readlink(p)
    st = p.lstat()
    if stat.S_ISLNK(st.st_mode):
        return "link->" + os.readlink(p) + ":" + sha256(p.resolve())
    if stat.S_ISDIR(st.st_mode):
        return "dir:" + ",".join(sorted(x.name for x in p.iterdir()))
    if not stat.S_ISREG(st.st_mode):
        return f"special:{stat.S_IFMT(st.st_mode)}"
    return hashlib.sha256(p.read_bytes()).hexdigest()


# ----------------------------------------------------------------------------------------------- fixtures
def _copy_rec(d: Path, name: str, src: str = "sim_paper-straight.h5") -> Path:
    p = d / name
    shutil.copy(RECORDINGS / src, p)
    return p


def _set_attr(path: Path, dataset: str, key: str, value=None) -> None:
    import h5py

    with h5py.File(path, "r+") as f:
        if value is None:
            f[dataset].attrs.pop(key, None)
        else:
            f[dataset].attrs[key] = value


def make_fixtures(d: Path) -> dict[str, Path]:
    """Every file the cases read, in ``d``."""
    import gzip

    import h5py
    import numpy as np

    d.mkdir(parents=True, exist_ok=True)
    fx: dict[str, Path] = {}
    fx["rec"] = _copy_rec(d, "rec.h5")
    fx["rec2"] = _copy_rec(d, "rec2.h5")
    fx["notes"] = d / "notes.txt"
    fx["notes"].write_text("my field notes, not HDF5\n")
    # units wrong with scale_to_si 1 (or the factor to g / deg/s)
    fx["acc_g"] = _copy_rec(d, "acc_in_g.h5")
    _set_attr(fx["acc_g"], "imu/acc", "scale_to_si", 1.0 / 2048.0)  # int16 counts at +-16 g -> g
    fx["gyro_dps"] = _copy_rec(d, "gyro_in_dps.h5")
    _set_attr(fx["gyro_dps"], "imu/gyro", "scale_to_si", 1.0 / 16.4)  # counts at +-2000 dps -> deg/s
    fx["counts"] = _copy_rec(d, "raw_counts.h5")
    _set_attr(fx["counts"], "imu/acc", "scale_to_si")
    _set_attr(fx["counts"], "imu/gyro", "scale_to_si")
    # datasets of different lengths
    fx["uneven"] = _copy_rec(d, "uneven.h5")
    with h5py.File(fx["uneven"], "r+") as f:
        acc = f["imu/acc"][: f["imu/acc"].shape[0] // 2]
        attrs = dict(f["imu/acc"].attrs)
        for k in [k for k in attrs if k in ("DIMENSION_LIST",)]:
            attrs.pop(k)
        f["imu/acc"].attrs.pop("DIMENSION_LIST", None) if "DIMENSION_LIST" in f["imu/acc"].attrs else None
        del f["imu/acc"]
        ds = f["imu"].create_dataset("acc", data=acc)
        for k, v in attrs.items():
            ds.attrs[k] = v
    # an empty recording (no samples)
    fx["empty"] = d / "empty.h5"
    sys.path.insert(0, str(REPO))
    from bootnav.logger.recording import counts_channel, write_recording

    write_recording(fx["empty"], np.zeros(0), np.zeros((0, 3), np.int16), np.zeros((0, 3), np.int16),
                    acc_channel=counts_channel("acc", 16 * G / 32768), gyro_channel=counts_channel("gyro", 1e-3),
                    measured_rate=False)
    # a CSV cut in the middle of its gzip stream
    rows = "\n".join(f"{i / 100:.2f},0,0,9.81,0.01,0,0" for i in range(60000))
    full = gzip.compress(("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\n" + rows + "\n").encode())
    fx["cut_gz"] = d / "cut.csv.gz"
    fx["cut_gz"].write_bytes(full[: len(full) // 2])
    # a CSV with a time column (rate given on the command line too)
    fx["timecsv"] = d / "timed.csv"
    fx["timecsv"].write_text("t_s,ax,ay,az,gx,gy,gz\n" + "\n".join(
        f"{i / 100:.2f},0.1,0.2,9.8,0.01,0.02,0.03" for i in range(2000)) + "\n")
    # an SD-card log whose header has accel_fs=9
    from bootnav.logger.crc import crc16_ccitt_false
    from bootnav.logger.importers.sdlog import format_sd_header

    lines = [format_sd_header().replace("accel_fs=3", "accel_fs=9").rstrip("\n")]
    for i in range(400):
        body = f"{i * 5000},{i},0,0,2048,0,0,0,0"
        lines.append(f"{body}*{crc16_ccitt_false(body.encode()):04X}")
    fx["sd_fs9"] = d / "LOG00001.TXT"
    fx["sd_fs9"].write_text("\n".join(lines) + "\n")
    # deeply nested settings
    fx["deep"] = d / "deep.json"
    fx["deep"].write_text("[" * 100000 + "]" * 100000)
    fx["gap_settings"] = d / "gap.json"
    fx["gap_settings"].write_text('{"checks": {"max_gap_s": 3600}}')
    # a recording with a 1 h gap in the middle
    fx["gap1h"] = _copy_rec(d, "gap1h.h5")
    with h5py.File(fx["gap1h"], "r+") as f:
        t = f["imu/t_s"][()]
        t[len(t) // 2:] += 3600.0
        f["imu/t_s"][...] = t
    fx["link_target"] = _copy_rec(d, "link_target.h5")
    return fx


def _specials(d: Path, fx: dict[str, Path]) -> dict[str, Path]:
    """The files a copy cannot carry: a FIFO, a directory, a symlink, a non-empty output folder."""
    fx = {k: d / v.name for k, v in fx.items()}
    fx["fifo"] = d / "pipe.h5"
    os.mkfifo(fx["fifo"])
    fx["dir"] = d / "adir.h5"
    fx["dir"].mkdir()
    fx["link"] = d / "link.h5"
    fx["link"].symlink_to(fx["link_target"].name)
    fx["evalout"] = d / "evalout"
    fx["evalout"].mkdir()
    (fx["evalout"] / "mine.txt").write_text("keep me\n")
    fx["evalroot"] = d / "evalroot"
    fx["evalroot"].mkdir()
    (fx["evalroot"] / "manifest.json").write_text('{"trials": [{"id": "x/1", "set": "x"}]}')
    return fx


_TEMPLATE: dict = {}


def fixtures_in(d: Path) -> dict[str, Path]:
    """A fresh copy of every fixture in ``d`` (the files are built once per process)."""
    if "dir" not in _TEMPLATE:
        t = Path(tempfile.mkdtemp(prefix="bootnav-fixtures-"))
        _TEMPLATE["fx"] = make_fixtures(t)
        _TEMPLATE["dir"] = t
    shutil.copytree(_TEMPLATE["dir"], d, dirs_exist_ok=True)
    return _specials(d, _TEMPLATE["fx"])


# ----------------------------------------------------------------------------------------------- cases
@dataclass
class Case:
    name: str
    argv: list[str] | None = None  # bootnav arguments ({d} = the case folder, {fx:NAME} = a fixture)
    code: str | None = None  # Python code run instead (the API cases)
    inputs: tuple[str, ...] = ()  # fixtures that must not change
    expect: str = "refuse"  # "refuse": exit != 0 ; "ok": exit 0 ; "any"
    timeout: float = 90.0
    env: dict = field(default_factory=dict)
    fsize: int | None = None  # RLIMIT_FSIZE, bytes
    term_after: float | None = None  # send SIGTERM after this many seconds
    sig: int = signal.SIGTERM
    close_stdout: bool = False
    check: Callable | None = None  # (proc, d, fx) -> problem text or None
    words: tuple[str, ...] = ()  # stderr must contain each (case-insensitive)


def _absent(*names):
    def check(proc, d, fx):
        there = [n for n in names if (d / n).exists()]
        return f"exists: {', '.join(there)}" if there else None
    return check


def _no_partial(out: str):
    def check(proc, d, fx):
        o = d / out
        if not o.exists():
            return None
        files = sorted(str(p.relative_to(o)) for p in o.rglob("*") if p.is_file())
        hidden = [f for f in files if Path(f).name.startswith(".")]
        if hidden:
            return f"temp files left: {hidden}"
        if files and proc.returncode != 0:
            return f"partial outputs after an error: {files}"
        return None
    return check


def _eval_kept(proc, d, fx):
    mine = fx["evalout"] / "mine.txt"
    return None if mine.exists() and mine.read_text() == "keep me\n" else "eval removed an unrelated file"


API = "import bootnav, numpy as np\n"
CASES: list[Case] = [
    # -- user files destroyed
    Case("simulate --out EXISTING.h5", ["simulate", "--scenario", "paper-straight", "--out", "{fx:rec}"], inputs=("rec",),
         words=("exists", "--force")),
    Case("simulate --out notes.txt", ["simulate", "--scenario", "paper-straight", "--format", "h5", "--out", "{fx:notes}"],
         inputs=("notes",)),
    Case("simulate --out notes.txt --force", ["simulate", "--scenario", "paper-straight", "--format", "h5", "--out",
                                              "{fx:notes}", "--force"], inputs=("notes",), words=("not an HDF5",)),
    Case("emulate --out-link EXISTING.h5", ["emulate", "--out-link", "{fx:rec}", "--duration", "1", "--no-wait"],
         inputs=("rec",), timeout=30),
    Case("record --out notes.txt --force", ["record", "--port", "loop://", "--out", "{fx:notes}", "--force",
                                            "--duration", "0.5", "--connect-timeout", "1"], inputs=("notes",),
         words=("not an HDF5",)),
    Case("eval --out NON-EMPTY", ["eval", "{fx:evalroot}", "--out", "{fx:evalout}"], check=_eval_kept,
         words=("not empty", "--force")),
    # -- hangs
    Case("info FIFO", ["info", "{fx:fifo}"], timeout=20, words=("FIFO",)),
    Case("import FIFO", ["import", "{fx:fifo}", "--out", "{d}/x.h5"], timeout=20, words=("FIFO",)),
    Case("process FIFO", ["process", "{fx:fifo}", "--out", "{d}/o"], timeout=20, words=("FIFO",)),
    Case("pdr FIFO", ["pdr", "{fx:fifo}", "--out", "{d}/o"], timeout=20, words=("FIFO",)),
    Case("process --settings FIFO", ["process", "{fx:rec}", "--settings", "{fx:fifo}", "--out", "{d}/o"], timeout=20,
         words=("FIFO",)),
    Case("info /dev/zero", ["info", "/dev/zero"], timeout=20),
    Case("info DIRECTORY", ["info", "{fx:dir}"], timeout=20),
    Case("simulate --duration 1e9", ["simulate", "--scenario", "shuffle", "--duration", "1e9", "--out", "{d}/s.h5"],
         timeout=30, words=("--duration",)),
    # -- tracebacks and crashes
    Case("process under ulimit -f", ["process", "{fx:rec}", "--out", "{d}/o", "--no-plots"], inputs=("rec",),
         fsize=300_000, timeout=180, check=_no_partial("o")),
    Case("API process(strings)", code=API + "bootnav.process('a', 'b', 'c')"),
    Case("API process(None)", code=API + "bootnav.process(None)"),
    Case("API process(arrays of None)", code=API + "bootnav.process(np.arange(10.0), None, None)"),
    Case("API process(int)", code=API + "bootnav.process(3, 4, 5)"),
    Case("API process(int)", code=API + "bootnav.process(5)"),
    Case("API pdr mag wrong shape", code=API + "t=np.arange(1000)/100.0\nacc=np.tile([0,0,9.81],(1000,1))\n"
         "bootnav.pdr(t, acc, np.zeros((1000,3)), mag_b=np.zeros((7,2)))"),
    # -- silent nonsense
    Case("process acc in g (scale 1)", ["process", "{fx:acc_g}", "--out", "{d}/o", "--no-plots"], inputs=("acc_g",),
         words=("gravity",)),
    Case("process gyro in deg/s", ["process", "{fx:gyro_dps}", "--out", "{d}/o", "--no-plots"], inputs=("gyro_dps",),
         words=("gyro",)),
    Case("process raw counts, no scale", ["process", "{fx:counts}", "--out", "{d}/o", "--no-plots"], inputs=("counts",)),
    Case("info acc in g", ["info", "{fx:acc_g}"], expect="any", words=("gravity",)),
    Case("settings max_gap_s 3600", ["process", "{fx:gap1h}", "--settings", "{fx:gap_settings}", "--out", "{d}/o",
                                     "--no-plots"], words=("max_gap_s",)),
    Case("--geo-anchor 45,9,nan", ["process", "{fx:rec}", "--geo-anchor", "45,9,nan", "--out", "{d}/o", "--no-plots"],
         words=("geo-anchor",)),
    Case("info uneven datasets", ["info", "{fx:uneven}"], expect="any", words=("length",)),
    Case("info cut .csv.gz", ["info", "{fx:cut_gz}"], expect="any", words=("warning",)),
    Case("pdr --step-length 0", ["pdr", "{fx:rec}", "--step-length", "0", "--out", "{d}/o"], words=("--step-length",)),
    Case("pdr --step-length 1e9", ["pdr", "{fx:rec}", "--step-length", "1e9", "--out", "{d}/o"],
         words=("--step-length",)),
    Case("pdr --weinberg-k -1", ["pdr", "{fx:rec}", "--weinberg-k", "-1", "--out", "{d}/o"], words=("--weinberg-k",)),
    Case("import --rate 1e9 (time column)", ["import", "{fx:timecsv}", "--rate", "1e9", "--out", "{d}/t.h5"],
         words=("--rate",)),
    Case("same file as two boots", ["process", "{fx:rec}", "{fx:rec}", "--two-boots", "--out", "{d}/o"],
         words=("same",)),
    Case("--into-recording on a symlink", ["process", "{fx:link}", "--into-recording", "--out", "{d}/o", "--no-plots"],
         expect="any", check=lambda p, d, fx: None if fx["link"].is_symlink() else "the link was replaced by a file"),
    # -- errors a user cannot act on
    Case("process --jobs -3", ["process", "{fx:rec}", "{fx:rec2}", "--jobs", "-3", "--out", "{d}/o"],
         words=("--jobs",)),
    Case("eval --jobs 0", ["eval", "{d}", "--jobs", "0", "--out", "{d}/e"], words=("--jobs",)),
    Case("deeply nested settings", ["process", "{fx:rec}", "--settings", "{fx:deep}", "--out", "{d}/o"],
         words=("nested",)),
    Case("SD header accel_fs=9", ["import", "{fx:sd_fs9}", "--out", "{d}/sd.h5"], words=("accel_fs",)),
    Case("live --replay empty", ["live", "--replay", "{fx:empty}", "--http-port", "0", "--speed", "100"],
         timeout=30),
    Case("ASCII console", ["info", "{fx:rec}"], expect="ok", env={"PYTHONIOENCODING": "ascii", "LC_ALL": "C"}),
    Case("cp1252 console", ["simulate", "--list"], expect="ok", env={"PYTHONIOENCODING": "cp1252"}),
    Case("stdout closed", ["info", "{fx:rec}"], expect="any", close_stdout=True),
    Case("--out in a missing directory", ["simulate", "--scenario", "paper-straight", "--out", "{d}/nodir/x.h5"],
         check=lambda p, d, fx: "names the temp file" if ".tmp" in p.stderr else None),
    Case("process --save-settings missing dir", ["process", "{fx:rec}", "--save-settings", "{d}/nodir/s.json",
                                                  "--out", "{d}/o"],
         check=lambda p, d, fx: "names the temp file" if ".tmp" in p.stderr else None),
    # -- signals
    Case("process SIGTERM", ["process", "{fx:rec}", "{fx:rec2}", "--jobs", "1", "--out", "{d}/o"], inputs=("rec",),
         term_after=4.0, expect="any", check=_no_partial("o")),
    Case("process SIGHUP", ["process", "{fx:rec}", "--out", "{d}/o"], inputs=("rec",), sig=signal.SIGHUP,
         term_after=4.0, expect="any", check=_no_partial("o")),
    Case("import SIGTERM", ["import", "{fx:timecsv}", "--acc-unit", "mps2", "--gyro-unit", "radps", "--out",
                            "{d}/t.h5"], term_after=0.8, expect="any",
         check=_absent(".t.h5.tmp")),
]


def _expand(argv, d: Path, fx) -> list[str]:
    out = []
    for a in argv:
        a = a.replace("{d}", str(d))
        if a.startswith("{fx:"):
            a = str(fx[a[4:-1]])
        out.append(a)
    return out


def run_case(case: Case, d: Path, fx: dict[str, Path]):
    """Run one case; returns (CompletedProcess-like, verdict text)."""
    before = {k: sha256(fx[k]) for k in case.inputs}
    env = {**os.environ, "PYTHONPATH": str(REPO), **case.env}
    cmd = bootnav_cmd() + _expand(case.argv, d, fx) if case.argv is not None else [sys.executable, "-c", case.code]

    def pre():
        os.setsid()
        if case.fsize is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (case.fsize, case.fsize))
        if case.close_stdout:
            os.close(1)

    t0 = time.monotonic()
    proc = subprocess.Popen(cmd, cwd=d, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            stdin=subprocess.DEVNULL, text=True, errors="replace", preexec_fn=pre)
    hung = False
    try:
        if case.term_after is not None:
            try:
                proc.wait(case.term_after)
            except subprocess.TimeoutExpired:
                proc.send_signal(case.sig)
        out, err = proc.communicate(timeout=case.timeout)
    except subprocess.TimeoutExpired:
        hung = True
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
    proc.stdout_text, proc.stderr = out, err
    proc.elapsed = time.monotonic() - t0
    problems = []
    if hung:
        problems.append(f"HANG (> {case.timeout:g} s)")
    changed = [k for k in case.inputs if sha256(fx[k]) != before[k]]
    if changed:
        problems.append("DESTROYED " + ",".join(changed))
    if case.code is not None:  # the API raises: the exception must be bootnav's own, one line in its words
        last = [ln for ln in err.splitlines() if ln.strip()][-1:] or [""]
        if proc.returncode != 0 and not (last[0].startswith("bootnav.") and "InputError: " in last[0]):
            problems.append(f"API error is not an InputError: {last[0][:80]}")
    elif "Traceback" in err:
        problems.append("TRACEBACK")
    if proc.returncode is not None and proc.returncode < 0 and case.term_after is None:
        problems.append(f"CRASH (signal {-proc.returncode})")
    if case.term_after is not None and proc.returncode is not None and proc.returncode < 0:
        problems.append(f"killed by signal {-proc.returncode}, no handler")
    if "unexpected" in err.lower():
        problems.append("UNEXPECTED")
    if not hung:
        if case.expect == "refuse" and proc.returncode == 0:
            problems.append("accepted (exit 0)")
        if case.expect == "ok" and proc.returncode != 0:
            problems.append(f"failed (exit {proc.returncode})")
    for w in case.words:
        if w.lower() not in (err + (out or "")).lower():
            problems.append(f"no '{w}' in stderr")
    if case.check is not None and not hung:
        extra = case.check(proc, d, fx)
        if extra:
            problems.append(extra)
    return proc, "; ".join(problems) or "ok"


def first_line(text: str) -> str:
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.startswith(("bootnav process: load",
                                                                                  "bootnav process: compiling"))]
    if lines and lines[0].startswith("Traceback"):
        return lines[-1][:150]
    return lines[0][:150] if lines else ""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default=None, help="run only cases whose name contains this")
    ap.add_argument("--keep", default=None, help="build fixtures in this folder and keep it")
    args = ap.parse_args(argv)
    root = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="bootnav-probe-"))
    bad = 0
    try:
        for i, case in enumerate(CASES):
            if args.only and args.only.lower() not in case.name.lower():
                continue
            d = root / f"case{i:02d}"
            fx = fixtures_in(d)
            proc, verdict = run_case(case, d, fx)
            bad += verdict != "ok"
            unchanged = "n/a" if not case.inputs else ("yes" if "DESTROYED" not in verdict else "NO")
            print(f"{case.name:38s} | {proc.returncode!s:>4} | {proc.elapsed:5.1f} s | inputs unchanged: {unchanged:3s} "
                  f"| {first_line(proc.stderr)} | {verdict}", flush=True)
    finally:
        if not args.keep:
            shutil.rmtree(root, ignore_errors=True)
        if "dir" in _TEMPLATE:
            shutil.rmtree(_TEMPLATE["dir"], ignore_errors=True)
    print(f"{bad} case(s) with a problem")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
