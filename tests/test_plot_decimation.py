"""Charts from a decimated stream (issue 18): ``decimate.TimeEnvelope`` keeps every column's extremes, a
one-sample spike included; fed in any chunking it gives exactly what one push gives; its drawing covers the
pixels the samples would; and ``process --chunk-s`` draws the same chart files as the whole run."""

from __future__ import annotations

import numpy as np
import pytest

from bootnav.postproc.decimate import PathExtremes, TimeEnvelope


def _walk_like(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Irregular times (200 Hz with jitter and a 0.5 s gap) and two noisy periodic signals with one spike."""
    rng = np.random.default_rng(seed)
    dt = 0.005 * (1 + 0.2 * rng.uniform(-1, 1, n))
    dt[n // 3] = 0.5
    t = 12.0 + np.cumsum(dt)
    y = np.column_stack((30 * np.sin(2 * np.pi * t) ** 9 + rng.normal(0, 0.3, n), rng.normal(0, 1, n)))
    y[n // 2 + 7, 1] = 250.0  # one sample far above everything else
    return t, y


def _chunks(n: int, rng) -> list[tuple[int, int]]:
    cuts = np.unique(np.r_[0, rng.integers(1, n, size=rng.integers(3, 40)), n])
    return list(zip(cuts[:-1], cuts[1:]))


def test_envelope_holds_every_sample_and_its_spike():
    t, y = _walk_like(50_000, seed=1)
    n_cols = 700
    env = TimeEnvelope(t[0], t[-1], n_cols, len(t), 2)
    env.push(t, y)
    assert not env.whole
    with pytest.raises(ValueError):
        env.samples()
    col = np.minimum(np.floor((t - t[0]) / (t[-1] - t[0]) * n_cols).astype(int), n_cols - 1)  # equal columns
    for c in np.unique(col):  # the column's exact extremes, attained by one of its samples
        inside = col == c
        np.testing.assert_array_equal(env.lo[c], y[inside].min(axis=0))
        np.testing.assert_array_equal(env.hi[c], y[inside].max(axis=0))
    empty = np.setdiff1d(np.arange(n_cols), col)
    assert len(empty) > 0  # the 0.5 s gap leaves columns without samples; they are not drawn
    t_band, lo, hi, filled = env.band()
    np.testing.assert_array_equal(filled, np.isin(np.arange(n_cols), col))  # empty columns are not drawn
    assert hi[filled, 1].max() == 250.0 and hi[col[len(t) // 2 + 7], 1] == 250.0  # the one-sample spike survives
    assert np.all(np.diff(t_band) > 0)
    t0, y0, t1, y1 = env.joins()  # the gap is bridged from its last sample before to its first after
    gap = len(t) // 3
    np.testing.assert_array_equal(np.c_[t0, t1], [[t[gap - 1], t[gap]]])
    np.testing.assert_array_equal(np.vstack((y0, y1)), y[gap - 1: gap + 1])


def test_short_record_is_kept_sample_by_sample():
    t, y = _walk_like(1_000, seed=2)
    env = TimeEnvelope(t[0], t[-1], 500, len(t), 2)  # n <= 2 columns: drawn as the samples
    env.push(t[:400], y[:400])
    env.push(t[400:], y[400:])
    assert env.whole
    t2, y2 = env.samples()
    np.testing.assert_array_equal(t2, t)
    np.testing.assert_array_equal(y2, y)
    path = PathExtremes(t[0], t[-1], 1_000, len(t), 2)
    path.push(t, y)
    idx, t3, p3 = path.points()
    np.testing.assert_array_equal(idx, np.arange(len(t)))
    np.testing.assert_array_equal(p3, y)


def test_streamed_decimation_equals_the_whole_array_one():
    rng = np.random.default_rng(3)
    t, y = _walk_like(30_000, seed=3)
    pos = np.column_stack((np.cumsum(y[:, 0]) * 1e-3, np.cumsum(y[:, 1]) * 1e-2, np.round(y[:, 0], 1)))  # ties in z
    whole_env, whole_path = TimeEnvelope(t[0], t[-1], 640, len(t), 2), PathExtremes(t[0], t[-1], 3000, len(t), 3)
    whole_env.push(t, y)
    whole_path.push(t, pos)
    for _ in range(5):
        env, path = TimeEnvelope(t[0], t[-1], 640, len(t), 2), PathExtremes(t[0], t[-1], 3000, len(t), 3)
        for a, b in _chunks(len(t), rng):
            env.push(t[a:b], y[a:b])
            path.push(t[a:b], pos[a:b])
        for mine, theirs in zip(env.band() + env.joins(), whole_env.band() + whole_env.joins()):
            np.testing.assert_array_equal(mine, theirs)
        for mine, theirs in zip(path.points(), whole_path.points()):
            np.testing.assert_array_equal(mine, theirs)


def test_path_keeps_each_columns_extreme_samples():
    t, y = _walk_like(20_000, seed=4)
    pos = np.column_stack((np.cumsum(y[:, 0]) * 1e-3, np.cumsum(y[:, 1]) * 1e-2, np.sin(t)))
    path = PathExtremes(t[0], t[-1], 602, len(t), 3)  # (602 - 2) / 6 = 100 columns
    path.push(t, pos)
    idx, t_kept, kept = path.points()
    assert len(idx) <= 602 and idx[0] == 0 and idx[-1] == len(t) - 1 and np.all(np.diff(idx) > 0)
    np.testing.assert_array_equal(kept, pos[idx])
    np.testing.assert_array_equal(t_kept, t[idx])
    col = np.minimum(np.floor((t - t[0]) / (t[-1] - t[0]) * path.n_cols).astype(int), path.n_cols - 1)
    for c in np.unique(col):
        inside = np.flatnonzero(col == c)
        for k in range(3):
            for at in (np.argmin(pos[inside, k]), np.argmax(pos[inside, k])):  # first sample at each extreme
                assert inside[at] in idx


def _ink(draw) -> np.ndarray:
    """Pixels (bool image) that ``draw(ax)`` colours on a time chart's axes, frame, ticks and grid off."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bootnav.postproc.plots import DPI, TIME_FIG_W_IN

    fig = plt.figure(figsize=(TIME_FIG_W_IN, 4.5), dpi=DPI)
    ax = fig.add_axes((0.07, 0.1, 0.91, 0.85))
    draw(ax)
    ax.set_axis_off()
    ax.set_xlim(0, 60)
    ax.set_ylim(-40, 260)
    fig.canvas.draw()
    rgb = np.asarray(fig.canvas.buffer_rgba())[..., :3]
    plt.close(fig)
    return (rgb < 200).any(axis=2)


def test_decimated_drawing_covers_the_pixels_of_the_samples():
    """The band of a 12 000-sample signal colours the pixels its samples' line colours, each within one
    pixel (a column is at most one pixel wide), the one-sample spike included."""
    from scipy.ndimage import binary_dilation

    from bootnav.postproc.plots import TIME_COLUMNS, _trace

    t, y = _walk_like(12_000, seed=5)
    t = (t - t[0]) * 60 / (t[-1] - t[0])
    full = TimeEnvelope(t[0], t[-1], len(t), len(t), 2)
    fewer = TimeEnvelope(t[0], t[-1], TIME_COLUMNS, len(t), 2)
    full.push(t, y)
    fewer.push(t, y)
    assert full.whole and not fewer.whole
    raw = _ink(lambda ax: [_trace(ax, full, k, "k", 0.8) for k in (0, 1)])
    band = _ink(lambda ax: [_trace(ax, fewer, k, "k", 0.8) for k in (0, 1)])
    near = np.ones((3, 3), bool)
    assert raw.sum() > 10_000
    assert not np.any(raw & ~binary_dilation(band, near))  # nothing the samples draw is missing
    assert not np.any(band & ~binary_dilation(raw, near))  # nothing is drawn that the samples do not draw
    spike_rows = np.flatnonzero(raw[:300].any(axis=1))  # above y = 50 (row ~319) only the spike is drawn
    assert len(spike_rows) and band[spike_rows].any()


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    from bootnav.simulator.simulate import LongSimulation
    from bootnav.simulator.writers import write_long_h5

    d = tmp_path_factory.mktemp("charts")
    return d, write_long_h5(LongSimulation(30.0, seed=7, block_s=20.0), d / "walk.h5")


def test_chunked_process_draws_the_whole_runs_charts(walk):
    """6000 samples: time charts in columns (> 2 x 1100 samples), path decimated (> plot_max_points)."""
    from matplotlib.image import imread

    from bootnav.postproc.outputs import write_outputs
    from bootnav.postproc.pipeline import process, process_to
    from bootnav.postproc.plots import FILES, TIME_COLUMNS
    from bootnav.postproc.settings import ProcessSettings
    from bootnav.postproc.strides import ELLIPSE_COLUMNS

    d, rec = walk
    settings = ProcessSettings()
    settings.output.plot_max_points = 1500
    settings.output.write_hdf5 = False
    whole = process(rec, settings)
    assert all(c in whole.steps for c in ELLIPSE_COLUMNS)  # drawn by both runs
    files_whole = write_outputs(whole, d / "whole")
    settings.block_s = 3.7
    summary, files_chunked = process_to(rec, settings, d / "chunked")
    assert summary["navigation"]["blocks"] > 1
    assert summary["input"]["samples_total"] > max(2 * TIME_COLUMNS, settings.output.plot_max_points)  # decimated
    names = [*FILES.values(), "path.html"]
    assert sorted(k for k in files_chunked if k.startswith("plot_") or k == "html") == \
        sorted(k for k in files_whole if k.startswith("plot_") or k == "html")
    assert "plots" in summary["timings_s"]
    for name in names:
        assert (d / "chunked" / name).is_file(), name
    for name in FILES.values():
        a, b = imread(d / "whole" / name), imread(d / "chunked" / name)
        assert a.shape == b.shape
        np.testing.assert_array_equal(a, b, err_msg=name)
    # path.html: the same decimated path and strides (coordinates printed to the mm)
    assert (d / "chunked" / "path.html").read_text() == (d / "whole" / "path.html").read_text()
