"""Issue 13's remaining gaps: tty-aware ``process`` progress, HDF5 1.10-readable bundled recordings,
dimension scales on ``/results``, ``import --profile list`` and ``info`` on any importable file."""

from __future__ import annotations

import json
import os
import pty
import subprocess
import sys

import numpy as np
import pytest

from tests.conftest import REPO

RECORDING = REPO / "recordings" / "xio_ngimu_short_walk.h5"


def _process_stderr(tmp_path, *, tty: bool) -> str:
    """stderr of ``bootnav process`` on the short bundled recording, on a pseudo-terminal or a pipe."""
    cmd = [sys.executable, "-m", "bootnav.cli", "process", str(RECORDING), "--out", str(tmp_path / "out"),
           "--no-plots", "--no-hdf5"]
    if not tty:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, cwd=REPO)
        assert proc.returncode == 0, proc.stderr
        return proc.stderr
    master, slave = pty.openpty()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=slave, cwd=REPO)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:  # EIO: the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    assert proc.wait(timeout=120) == 0
    return b"".join(chunks).decode()


def test_process_progress_rewrites_one_line_on_a_tty(tmp_path):
    text = _process_stderr(tmp_path, tty=True).replace("\r\n", "\n")  # the terminal's own newline mapping
    assert "\r" in text and "bootnav process:" in text  # a carriage return written by the progress itself
    # the line is rewritten, never scrolled: no stage line is left as a line of its own
    assert not any(line.startswith("bootnav process:") for line in text.split("\n"))


def test_process_progress_is_plain_lines_in_a_log(tmp_path):
    text = _process_stderr(tmp_path, tty=False)
    assert "\r" not in text
    lines = text.splitlines()
    assert lines and all(line.startswith("bootnav process: ") for line in lines)
    assert any(line.endswith(" s)") and " navigation done " in line for line in lines)


def test_process_quiet_shows_no_progress(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "bootnav.cli", "process", str(RECORDING), "--out",
                           str(tmp_path / "out"), "--no-plots", "--no-hdf5", "--quiet"],
                          capture_output=True, text=True, timeout=120, cwd=REPO)
    assert proc.returncode == 0 and proc.stderr == ""


def test_results_group_opens_in_xarray_with_named_dimensions(tmp_path):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    rec = REPO / "recordings" / "sim_paper-straight.h5"
    proc = subprocess.run([sys.executable, "-m", "bootnav.cli", "process", str(rec), "--out", str(tmp_path / "out"),
                           "--no-plots", "--quiet"], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    h5 = tmp_path / "out" / "results.h5"
    with xr.open_dataset(h5, engine="h5netcdf", group="results/default", phony_dims="sort") as ds:
        assert not [d for d in ds.sizes if str(d).startswith("phony")], dict(ds.sizes)
        assert ds["pos_n_m"].dims == ("sample", "axis") and ds["q_nb"].dims == ("sample", "q_component")
        assert ds["stance"].dims == ("sample",) and ds.sizes["sample"] > 1000
        assert list(ds["axis"].values) == ["x", "y", "z"]  # str, not bytes (issue 26)
        # the time coordinate is the results' own time axis, one row per processed sample, along the row index
        assert "t_s" in ds.coords and ds["t_s"].dims == ("sample",)
        assert float(ds["t_s"][0]) == 0.0 and bool((ds["t_s"].diff("sample") > 0).all())
    with xr.open_dataset(h5, engine="h5netcdf", group="results/default/steps", phony_dims="sort") as steps:
        assert set(steps.sizes) == {"stride"} and steps.sizes["stride"] >= 5
        assert steps["stride_length_m"].dims == ("stride",)


def _bootnav(*args):
    return subprocess.run([sys.executable, "-m", "bootnav.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=120, cwd=REPO)


def test_import_profile_list_needs_no_input_file():
    proc = _bootnav("import", "--profile", "list")
    assert proc.returncode == 0, proc.stderr
    names = [line.split()[0] for line in proc.stdout.splitlines() if line.strip()]
    assert "canonical_imu_csv" in names and "heidari2019_sd_txt" in names
    missing = _bootnav("import")  # without --profile list the file is still required: a usage error
    assert missing.returncode == 2 and "input file is required" in missing.stderr


def test_info_reads_what_process_reads(tmp_path):
    """A canonical CSV (which ``process`` accepts) is summarised as the recording ``import`` writes from it."""
    dt = np.full(400, 0.01)
    dt[[200, 300]] = [0.016, 0.032]  # one and two lost samples (the one gap rule)
    t = np.round(np.r_[0.0, np.cumsum(dt)], 4)
    csv = tmp_path / "walk.csv"
    csv.write_text("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\n"
                   + "\n".join(f"{x:.4f},0.1,0,9.80665,0.2,0,0" for x in t) + "\n")
    proc = _bootnav("info", csv, "--json")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.endswith("}\n")  # a JSON document ends with a newline, like every text output
    from_csv = json.loads(proc.stdout)
    imported = tmp_path / "walk.h5"
    assert _bootnav("import", csv, "--out", imported, "--quiet").returncode == 0
    from_h5 = json.loads(_bootnav("info", imported, "--json").stdout)
    assert from_csv["frames"] == t.size and from_csv["gaps"] == 2 and from_csv["dropped"] == 3
    assert from_csv["file"] == str(csv)
    skip = {"file", "start_utc"}  # the input's name, and the import's wall-clock time when the file has none
    assert {k: v for k, v in from_csv.items() if k not in skip} == {k: v for k, v in from_h5.items() if k not in skip}
    text = _bootnav("info", csv)
    assert text.returncode == 0 and "samples     401" in text.stdout


def test_info_on_a_broken_h5_is_still_reported_as_a_recording(tmp_path):
    bad = tmp_path / "cut.h5"
    bad.write_bytes(b"t_s,ax\n0,1\n")  # not HDF5: never guessed to be a CSV because of its name
    proc = _bootnav("info", bad)
    assert proc.returncode == 1 and "cannot open" in proc.stderr
