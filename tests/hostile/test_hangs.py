"""Nothing blocks forever: a vanished host, a stream of pure garbage, a half-copied recording."""

from __future__ import annotations

import os
import threading
import time
import tty

import numpy as np
import pytest

from bootnav.cli import main
from bootnav.logger.emulator import Emulator, EmulatorSettings


@pytest.mark.timeout(30)
def test_emulator_gives_up_when_the_host_stops_reading(tmp_path):
    """Nobody reads the pty: the kernel buffer fills and the write times out instead of hanging."""
    settings = EmulatorSettings(out_link=str(tmp_path / "boot"), duration_s=60.0, rate_hz=5000.0,
                                wait_for_host=False, write_timeout_s=0.3, linger_s=0.0)
    emulator = Emulator(settings)
    t0 = time.monotonic()
    with pytest.raises(TimeoutError, match="stopped reading"):
        emulator.run()
    # it streamed until the buffer was full, then waited write_timeout_s, not the 60 s of the stream
    assert time.monotonic() - t0 < 20
    assert emulator.report.bytes_sent > 0
    assert not (tmp_path / "boot").exists()  # the link is removed on the way out


@pytest.mark.timeout(30)
def test_garbage_only_stream_exits_non_zero_without_a_file(tmp_path, capsys):
    master, slave = os.openpty()
    tty.setraw(slave)
    port = os.ttyname(slave)
    stop = threading.Event()
    rng = np.random.default_rng(3)
    # bytes that never contain the protocol's sync word 0xA5 0x5A, so no frame can be valid by chance
    junk = rng.integers(0, 256, 4096, dtype=np.uint8)
    junk[junk == 0xA5] = 0x00
    sent = [0]

    def feed():
        os.set_blocking(master, False)
        while not stop.is_set():
            try:
                sent[0] += os.write(master, junk.tobytes())
            except BlockingIOError:
                pass
            try:
                os.read(master, 1024)  # the recorder's header requests
            except BlockingIOError:
                pass
            time.sleep(0.01)

    thread = threading.Thread(target=feed, daemon=True)
    thread.start()
    out = tmp_path / "garbage.h5"
    try:
        code = main(["record", "--port", port, "--out", str(out), "--duration", "1", "--quiet"])
    finally:
        stop.set()
        thread.join()
        os.close(master)
        os.close(slave)
    err = capsys.readouterr().err
    assert code == 1
    assert "Traceback" not in err
    line = err.strip().splitlines()[-1]
    assert line.startswith("bootnav record: error: no valid frame in ") and " bytes from " in line, line
    n_bytes = int(line.split("no valid frame in ")[1].split()[0])
    assert 0 < n_bytes <= sent[0]
    assert not out.exists()
