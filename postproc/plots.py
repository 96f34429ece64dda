"""The paper's charts 1-7 [Heidari2019, Charts 1-7] as PNG files, readable at a glance.

1. ``1_raw_imu.png``: raw accelerometer and gyroscope with the stance indicator (Chart 1).
2. ``2_acc_gravity_free.png``: acceleration in the nav frame with gravity removed, components and
   magnitude: a_n = C_nb f_b + g_n, g_n = [0, 0, −g] (Chart 2).
3. ``3_velocity.png``: velocity in the nav frame; zero in stance thanks to ZUPT (Chart 3).
4. ``4_position.png``: position vs time, x/y/z (Charts 4 and 6), the reference dotted when given.
5. ``5_path_2d.png``: the path seen from above, equal axes, reference dotted when given (Charts 5 and 7).
6. ``6_path_3d.png``: the 3-D path with equal scales (Chart 7, stairs).
7. ``7_height.png``: height vs time with the floor lines used for counting floors, and the reference's.

Plus ``path.html`` (``make_html``): the path from above as a small self-contained interactive SVG page.

Time charts shade stance (green) and saturated intervals (red). Every chart is drawn from a decimated
stream (``ChartStream``, built on ``decimate``), the same for a whole run (``make_plots``) and a run in
blocks (``passes.BlockPasses`` feeds it block by block): time charts keep the minimum and the maximum
of every pixel column (``decimate.TimeEnvelope``), so a one-sample peak stays visible, and a column is shaded
if any of its samples is in stance or saturated; the path charts and ``path.html`` keep, per time column,
the samples at each coordinate's extremes (``decimate.PathExtremes``, at most
``OutputSettings.plot_max_points`` points), and every footprint. Records short enough are drawn sample by
sample. Every number in the files comes from the full data.

Every file is written to a hidden temporary file renamed over the target, so an interrupted run leaves no
half-written chart. Speed: matplotlib is imported only when drawing (``bootnav process`` draws in two forked
processes, warmed up by ``warm_up`` while the path is computed, each drawing a subset of the charts:
``outputs.ChartWorker``); each figure is drawn once (``tight_layout`` lays it out, then its placeholder layout
engine, which would make ``savefig`` draw twice, is removed); a decimated signal is a filled band (a line
zig-zagging between each column's extremes costs Agg several times more); the shading is one polygon
collection per axes; PNGs are compressed at zlib level 1.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bootnav.core import atomic
from bootnav.core.runs import runs

from .decimate import PathExtremes, TimeEnvelope
from .strides import ELLIPSE_COLUMNS, floor_levels, floor_signal, footprints
from .summary import endpoint_label

AXIS_COLORS = ("tab:red", "tab:green", "tab:blue")  # x, y, z (the usual RGB convention)
FILES = {
    "raw_imu": "1_raw_imu.png",
    "acc_gravity_free": "2_acc_gravity_free.png",
    "velocity": "3_velocity.png",
    "position": "4_position.png",
    "path_2d": "5_path_2d.png",
    "path_3d": "6_path_3d.png",
    "height": "7_height.png",
}
DPI = 110
TIME_FIG_W_IN = 10.0  # the time charts' width; their columns are its pixels (the axes are narrower)
TIME_COLUMNS = int(TIME_FIG_W_IN * DPI)
PNG_COMPRESS_LEVEL = 1  # zlib level: Pillow's default 6 takes 1.4x the time to encode, for files within ±15 %


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"figure.dpi": DPI, "axes.grid": True, "grid.alpha": 0.3, "legend.fontsize": 8,
                         "legend.framealpha": 0.85})
    return plt


def warm_up() -> None:
    """Import matplotlib and draw one tiny figure (fonts, Agg, PNG encoder loaded), so that the charts drawn
    next take only their own time: a chart process calls it while the path is being computed."""
    import io

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(1, 1))
    ax.plot([0, 1], [0, 1], label="x")
    ax.set_title("x")
    fig.savefig(io.BytesIO(), format="png", pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
    plt.close(fig)




def gravity_free_acc_n(q_nb: np.ndarray, acc_b: np.ndarray, gravity: float) -> np.ndarray:
    """a_n = C_nb(q_nb) f_b + [0, 0, −g] (m/s²), for unit quaternions wxyz (N, 4) and f_b (N, 3).

    The rotation is v + w c + u × c with c = 2 u × v and u the vector part (column arithmetic: np.cross is
    several times slower on (N, 3) arrays)."""
    q = np.asarray(q_nb, float)
    v = np.asarray(acc_b, float)
    w, ux, uy, uz = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    vx, vy, vz = v[:, 0], v[:, 1], v[:, 2]
    cx, cy, cz = 2.0 * (uy * vz - uz * vy), 2.0 * (uz * vx - ux * vz), 2.0 * (ux * vy - uy * vx)
    out = np.empty((len(q), 3))
    out[:, 0] = vx + w * cx + (uy * cz - uz * cy)
    out[:, 1] = vy + w * cy + (uz * cx - ux * cz)
    out[:, 2] = vz + w * cz + (ux * cy - uy * cx) - gravity
    return out


class ChartStream:
    """The decimated data charts 1-7 and ``path.html`` are drawn from, fed in time order chunk by chunk.

    ``push_imu`` takes the samples as read (specific force, angular rate, saturation), ``push_nav`` the
    navigator's output rows of the same samples (they may come later: the specific force of the samples
    not yet output waits in a queue, for chart 2); ``finish`` adds the footprints, strides and summary.
    Memory: the columns, the path's kept points, the footprints and the navigator's lag of specific force.

    Parameters
    ----------
    t_start_s, t_end_s : float
        First and last sample time of the run, s.
    n_samples : int
        Samples that will be pushed.
    gravity_mps2 : float
        g used by the run (chart 2 removes it).
    max_points : int
        ``OutputSettings.plot_max_points``: most points of a path line.
    time_charts : bool
        Keep the time charts' columns too (False: only what ``path.html`` draws).
    """

    def __init__(self, t_start_s: float, t_end_s: float, n_samples: int, gravity_mps2: float, max_points: int,
                 time_charts: bool = True):
        self.imu = self.nav = None
        if time_charts:
            self.imu = TimeEnvelope(t_start_s, t_end_s, TIME_COLUMNS, n_samples, 7)  # acc 3, gyro 3, saturated
            self.nav = TimeEnvelope(t_start_s, t_end_s, TIME_COLUMNS, n_samples, 11)  # a_n, |a_n|, vel, pos, stance
        self.path = PathExtremes(t_start_s, t_end_s, max(int(max_points), 100), n_samples, 3)
        self.gravity_mps2 = float(gravity_mps2)
        self._acc_queue: list[np.ndarray] = []
        self.info: dict = {}

    @classmethod
    def from_result(cls, result, time_charts: bool = True) -> ChartStream:
        """The stream of a whole run (``pipeline.ProcessResult``), pushed in one piece."""
        t = result.t_s
        s = cls(t[0], t[-1], len(t), result.gravity_mps2, result.settings.output.plot_max_points, time_charts)
        s.push_imu(t, result.acc_b, result.gyro_b, result.saturated)
        s.push_nav(t, result.pos_n, result.vel_n, result.q_nb, result.stance)
        reference = None
        if result.reference is not None and len(result.reference.points_n):
            from .reference_path import align_to_reference

            _, ref_pts, yaw = align_to_reference(result.reference, t, result.pos_n)
            reference = {"points": ref_pts, "yaw": yaw, "t_s": result.reference.t_s,
                         "est": reference_in_estimate_frame(ref_pts, yaw, result.pos_n[0])}
        s.finish(*footprints(t, result.pos_n, result.stance), result.steps, result.summary, result.settings,
                 result.metrics, reference)
        return s

    def push_imu(self, t_s, acc_b, gyro_b, saturated) -> None:
        """Samples as read: s, specific force m/s² (calibrated), rad/s, saturation (bool or bits)."""
        if self.imu is None:
            return
        y = np.empty((len(t_s), 7))
        y[:, 0:3], y[:, 3:6], y[:, 6] = acc_b, gyro_b, np.asarray(saturated) != 0
        self.imu.push(t_s, y)
        self._acc_queue.append(np.asarray(acc_b, float))

    def push_nav(self, t_s, pos_n, vel_n, q_nb, stance) -> None:
        """The navigator's rows of the next samples pushed by ``push_imu``: s, m, m/s, wxyz, bool."""
        m = len(t_s)
        if m == 0:
            return
        self.path.push(t_s, pos_n)
        if self.nav is None:
            return
        parts, have = [], 0
        while have < m:
            head = self._acc_queue[0]
            take = min(m - have, len(head))
            parts.append(head[:take])
            have += take
            if take == len(head):
                self._acc_queue.pop(0)
            else:
                self._acc_queue[0] = head[take:]
        y = np.empty((m, 11))
        y[:, 0:3] = a_n = gravity_free_acc_n(q_nb, parts[0] if len(parts) == 1 else np.vstack(parts),
                                             self.gravity_mps2)
        y[:, 3] = np.sqrt(a_n[:, 0] ** 2 + a_n[:, 1] ** 2 + a_n[:, 2] ** 2)  # row by row: the same in any chunking
        y[:, 4:7], y[:, 7:10], y[:, 10] = vel_n, pos_n, stance
        self.nav.push(t_s, y)

    def finish(self, t_fp, fp_n, steps, summary, settings, metrics=None, reference=None) -> None:
        """What the titles, footprints, floor lines and stride markers need.

        Parameters
        ----------
        t_fp, fp_n : (K,), (K, 3) arrays
            Footprints (``strides.footprints``): mid time of each stance phase, s, and its mean position, m.
        steps : dict
            Strides (``strides.STEP_COLUMNS``).
        summary : dict
            The run's summary (source, stance method, path statistics).
        settings : ProcessSettings
        metrics : dict or None
            Reference metrics.
        reference : dict or None
            ``points`` (reference from ``align_to_reference``), ``yaw``, ``t_s`` and ``est`` (its points in
            the estimate's frame).
        """
        self.info = {"t_fp": np.asarray(t_fp, float), "fp_n": np.asarray(fp_n, float).reshape(-1, 3),
                     "steps": steps, "summary": summary, "settings": settings, "metrics": metrics,
                     "reference": reference}

    def path_drawn(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times (M,) s, kept path points (M, 3) m and footprints (K, 3) m as the path charts show them: moved
        and turned onto the reference like ``reference_path.align_to_reference`` does, when one is given."""
        _, t, pos = self.path.points()
        fp = self.info["fp_n"]
        ref = self.info["reference"]
        if ref is not None:
            p0 = self.path.first[2]
            c, s = (np.cos(ref["yaw"]), np.sin(ref["yaw"])) if ref["yaw"] is not None else (1.0, 0.0)
            turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
            pos, fp = (pos - p0) @ turn.T, (fp - p0) @ turn.T
        return t, pos, fp


def _shade(ax, edges, on, color, label):
    """Shade the columns where ``on`` is True (columns ``edges``, s): one polygon per run of shaded columns,
    in one collection (thousands of stance phases would be thousands of artists: slow to draw)."""
    if not on.any():
        return
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Patch

    a, b = runs(on)
    x0, x1 = edges[a], edges[b]
    if color == "tab:red":  # saturation: also a thin line per burst, visible at any zoom
        ax.vlines(0.5 * (edges[a] + edges[a + 1])[:500], 0, 1, transform=ax.get_xaxis_transform(), color=color,
                  lw=0.8, alpha=0.5, zorder=0.5)
    boxes = np.stack([np.column_stack(v) for v in ((x0, np.zeros_like(x0)), (x1, np.zeros_like(x0)),
                                                  (x1, np.ones_like(x0)), (x0, np.ones_like(x0)))], axis=1)
    ax.add_collection(PolyCollection(boxes, transform=ax.get_xaxis_transform(), facecolors=color, alpha=0.13,
                                     linewidths=0, antialiaseds=False, zorder=0), autolim=False)
    if label:
        ax._bootnav_legend_extra = getattr(ax, "_bootnav_legend_extra", []) + [Patch(color=color, alpha=0.25, label=label)]


def _legend(ax, **kw):
    """Legend of the drawn lines plus the shading entries (collections have no legend entry of their own)."""
    handles, labels = ax.get_legend_handles_labels()
    extra = getattr(ax, "_bootnav_legend_extra", [])
    ax.legend(handles + extra, labels + [p.get_label() for p in extra], **kw)


def _trace(ax, env: TimeEnvelope, k: int, color, lw: float, label=None, offset: float = 0.0, **kw):
    """Signal k of a ``TimeEnvelope``: its samples as a line when the record was kept whole, else the band
    from the minimum to the maximum of every column (a step per column), a line of the given width through
    its middle (where the band is thinner than the line) and the samples' straight line across gaps, so
    every peak is drawn where the samples would draw it. A line sweeping each column's minimum and maximum
    would draw the same pixels at several times the cost in Agg; an edged band looks bolder than a line (its
    two edges overlap)."""
    if env.whole:
        t, y = env.samples()
        ax.plot(t, y[:, k] - offset, color=color, lw=lw, label=label, **kw)
        return
    t, lo, hi, filled = env.band()
    lo, hi = lo[:, k] - offset, hi[:, k] - offset
    ax.fill_between(t, lo, hi, where=filled, step="mid", color=color, lw=0, zorder=2, **kw)  # in order with lines
    mid = np.full(len(t), np.nan)
    mid[filled] = 0.5 * (lo[filled] + hi[filled])
    ax.plot(t, mid, color=color, lw=lw, **kw)  # a line where the band is thinner than one
    t0, y0, t1, y1 = env.joins()
    if len(t0):  # across gaps in time, the straight line the samples draw
        nan = np.full(len(t0), np.nan)
        ax.plot(np.column_stack((t0, t1, nan)).ravel(),
                np.column_stack((y0[:, k], y1[:, k], nan)).ravel() - offset, color=color, lw=lw, **kw)
    if label:
        ax.plot([], [], color=color, lw=lw, label=label, **kw)  # the legend shows a line, as for the samples


def _lines(ax, env, first, labels, colors=AXIS_COLORS):
    for k, label in enumerate(labels):
        _trace(ax, env, first + k, colors[k % len(colors)], 0.8, label)


def make_plots(result, out_dir: str | Path) -> dict[str, Path]:
    """Write charts 1-7 of a whole run (``pipeline.ProcessResult``) into ``out_dir``; returns {name: path}."""
    return draw_charts(ChartStream.from_result(result), out_dir)


class _Charts:
    """What the charts of one ``draw_charts`` call share: pyplot, the output folder, the stream's summary and
    settings, the time axis with its stance and saturation shading, and the reference in the estimate's frame."""

    def __init__(self, stream: ChartStream, out_dir: str | Path, keys):
        self.plt = _pyplot()
        self.out = Path(out_dir)
        self.out.mkdir(parents=True, exist_ok=True)
        self.stream, self.keys = stream, keys
        self.info = info = stream.info
        self.summary, self.settings = info["summary"], info["settings"]
        self.imu, self.nav = stream.imu, stream.nav
        self.edges = stream.imu.column_edges_s()
        self.stance_on, self.sat_on = self.nav.hi[:, 10] > 0.5, self.imu.hi[:, 6] > 0.5  # a column with any such sample
        self.t0, self.t1 = stream.imu.t_start_s, stream.imu.t_end_s
        self.src = Path(str(self.summary["input"]["source"])).name
        self.paths: dict[str, Path] = {}
        ref = info["reference"]
        self.ref_pts = self.ref_t = self.ref_est = None
        self.title_ref = ""
        if ref is not None:
            self.ref_pts, self.ref_t, self.ref_est = ref["points"], ref["t_s"], ref["est"]
            if ref["yaw"] is not None:
                self.title_ref = f" (estimate rotated {np.degrees(ref['yaw']):+.1f}° onto the reference)"

    def save(self, fig, key):
        fig.tight_layout()
        fig.set_layout_engine(None)  # the placeholder tight_layout leaves would cost savefig a second draw
        png = {"format": "png", "pil_kwargs": {"compress_level": PNG_COMPRESS_LEVEL}}
        atomic.replace_with(self.out / FILES[key], lambda tmp: fig.savefig(tmp, **png))  # never half written
        self.plt.close(fig)
        self.paths[key] = self.out / FILES[key]

    def time_axes(self, ax, ylabel, first=False):
        _shade(ax, self.edges, self.stance_on, "tab:green", "stance" if first else None)
        _shade(ax, self.edges, self.sat_on, "tab:red", "saturated" if first else None)
        ax.set_ylabel(ylabel)
        ax.set_xlim(self.t0, self.t1)

    def time_chart(self, key, first, labels, ylabel, title, loc, extra=None, reference=None):
        """Charts 2-4: three nav-frame components against time, stance and saturation shaded."""
        if key not in self.keys:
            return
        fig, ax = self.plt.subplots(figsize=(TIME_FIG_W_IN, 4.5))
        _lines(ax, self.nav, first, labels)
        if extra is not None:
            _trace(ax, self.nav, extra, "k", 0.6, "|a|", alpha=0.6)
        if reference is not None:
            reference(ax)
        self.time_axes(ax, ylabel, first=True)
        ax.set_xlabel("time (s)")
        ax.set_title(title)
        _legend(ax, loc=loc, ncol=6 if extra is not None else 5)
        self.save(fig, key)

    def reference_vs_time(self, ax, offset=np.zeros(3), axes=(0, 1, 2)):
        """The reference on a time chart, in the estimate's frame: its curves when it has times, else its
        end point at the end of the recording."""
        if self.ref_est is None:
            return
        ref_t, ref_est, t0, t1 = self.ref_t, self.ref_est, self.t0, self.t1
        for k in axes:
            name = "reference" if k == axes[0] else None
            if ref_t is not None:
                inside = (ref_t >= t0) & (ref_t <= t1)
                ax.plot(ref_t[inside], ref_est[inside, k] - offset[k], ":", color=AXIS_COLORS[k] if len(axes) > 1
                        else "k", lw=1.6, label=name)
            else:
                ax.plot([t1], [ref_est[-1, k] - offset[k]], "*", ms=11, mec="k",
                        color=AXIS_COLORS[k] if len(axes) > 1 else "k", label=name and "reference end")


def _raw_imu_chart(c: _Charts) -> None:
    """Chart 1: raw IMU + stance."""
    fig, (a1, a2, a3) = c.plt.subplots(3, 1, figsize=(TIME_FIG_W_IN, 7), sharex=True,
                                       gridspec_kw={"height_ratios": [3, 3, 1]})
    _lines(a1, c.imu, 0, ["acc x", "acc y", "acc z"])
    c.time_axes(a1, "specific force (m/s²)", first=True)
    _legend(a1, loc="upper right", ncol=5)
    _lines(a2, c.imu, 3, ["gyro x", "gyro y", "gyro z"])
    c.time_axes(a2, "angular rate (rad/s)")
    _legend(a2, loc="upper right", ncol=3)
    _trace(a3, c.nav, 10, "k", 0.8)
    a3.set_ylim(-0.2, 1.2)
    a3.set_yticks([0, 1])
    a3.set_ylabel("stance")
    a3.set_xlabel("time (s)")
    a1.set_title(f"Raw IMU (body frame) with stance indicator — {c.src} — detector {c.summary['stance']['method']}")
    c.save(fig, "raw_imu")


def _path_stats(summary: dict, metrics: dict) -> str:
    """The path charts' figures: distance and end-point error or closure, then the reference metrics."""
    summ = summary.get("path", {})
    stats = f"distance {summ.get('distance_m', 0):.2f} m"
    m = metrics or {}
    if "final_error_m" in m:
        stats += f", end-point error {m['final_error_m']:.2f} m"
    elif "closure_3d_m" in summ:
        stats += f", {endpoint_label(summary)} {summ['closure_3d_m']:.2f} m ({summ['closure_pct']:.2f} %)"
    if "deviation_error_pct" in m:
        stats += (f"\ndistance err {m['distance_error_pct']:.1f} %, deviation {m['deviation_error_pct']:.1f} %, "
                  f"height err {m['height_error_pct']:.1f} %")
    elif "stride_mae_m" in m:
        stats += (f"\nstride length MAE {m['stride_mae_m']:.3f} m vs reference, "
                  f"distance err {m['distance_error_pct']:.1f} %")
    return stats


def _path_2d_chart(c: _Charts, pos: np.ndarray, fp: np.ndarray, stats: str) -> None:
    """Chart 5: the path from above."""
    fig, ax = c.plt.subplots(figsize=(7.5, 7.5))
    ax.plot(pos[:, 0], pos[:, 1], color="tab:blue", lw=0.9, label="estimated path (boot)")
    if len(fp):
        ax.plot(fp[:, 0], fp[:, 1], ".", color="tab:blue", ms=4, label="footprints (stance)")
    if c.ref_pts is not None:
        ax.plot(c.ref_pts[:, 0], c.ref_pts[:, 1], ":", color="k", lw=2, label="reference path")
    ax.plot(pos[0, 0], pos[0, 1], "o", color="tab:green", ms=9, label="start")
    ax.plot(pos[-1, 0], pos[-1, 1], "s", color="tab:red", ms=8, label="end")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_title(f"Path from above{c.title_ref}\n{stats}", fontsize=10)
    _legend(ax, loc="upper right")
    c.save(fig, "path_2d")


def _path_3d_chart(c: _Charts, pos: np.ndarray, stats: str) -> None:
    """Chart 6: the 3-D path, equal scales on the three axes."""
    fig = c.plt.figure(figsize=(8, 7))
    ax = fig.add_subplot(projection="3d")
    ax.plot(pos[:, 0], pos[:, 1], pos[:, 2], color="tab:blue", lw=0.9, label="estimated path")
    if c.ref_pts is not None:
        ax.plot(c.ref_pts[:, 0], c.ref_pts[:, 1], c.ref_pts[:, 2], ":", color="k", lw=2, label="reference path")
    ax.scatter(*pos[0], color="tab:green", s=40, label="start")
    ax.scatter(*pos[-1], color="tab:red", marker="s", s=40, label="end")
    lo, hi = pos.min(axis=0), pos.max(axis=0)
    span = max(float((hi - lo).max()), 1.0)
    mid = (lo + hi) / 2
    for setter, v in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), mid):
        setter(v - span / 2, v + span / 2)  # equal scale on all three axes
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_zlabel("z up (m)")
    ax.set_title(f"3-D path — {stats.splitlines()[0]}", fontsize=10)
    _legend(ax, loc="upper left")
    c.save(fig, "path_3d")


def _height_chart(c: _Charts) -> None:
    """Chart 7: height with the floor lines, the stair signal and the counted floor level."""
    summ = c.summary.get("path", {})
    floors = c.settings.floor_settings()
    fig, ax = c.plt.subplots(figsize=(TIME_FIG_W_IN, 4.5))
    t_fp, fp_n = c.info["t_fp"], c.info["fp_n"]
    z0 = float(fp_n[0, 2]) if len(fp_n) else float(c.stream.path.first[2][2])
    _trace(ax, c.nav, 9, "tab:blue", 0.9, "height of the boot", offset=z0)
    if len(fp_n):
        z_fp = fp_n[:, 2] - z0
        stair = floor_signal(z_fp, floors)
        # a level walk has no stair to draw (with storeys on, the signal is the held footprint height itself)
        if floors.stair_min_dz_m is not None and np.any(np.abs(np.diff(z_fp)) >= floors.stair_min_dz_m):
            ax.plot(t_fp, stair, color="tab:purple", lw=1, ls="--",
                    label=f"stair height (strides with |dz| >= {floors.stair_min_dz_m:g} m)")
        ax.step(t_fp, floor_levels(floor_signal(z_fp, floors), floors) * floors.floor_height_m, where="post",
                color="tab:orange", lw=1.5, label="floor level (counted)")
        zmin, zmax = min(z_fp.min(), 0.0), max(z_fp.max(), 0.0)
    else:
        zmin = zmax = 0.0
    k_lo = int(np.round(zmin / floors.floor_height_m)) - 1  # one storey of context below and above
    k_hi = int(np.round(zmax / floors.floor_height_m)) + 1
    for k in range(k_lo, k_hi + 1):
        ax.axhline(k * floors.floor_height_m, color="grey", ls="--", lw=0.8)
        ax.text(c.t1, k * floors.floor_height_m, f"floor {k:+d} " if k else "start floor ", va="bottom",
                ha="right", fontsize=8, color="grey")
    c.reference_vs_time(ax, offset=np.array([0.0, 0.0, z0]), axes=(2,))
    c.time_axes(ax, "height above start (m)", first=True)
    ax.set_xlabel("time (s)")
    ax.set_title(f"Height vs time — floors climbed {summ.get('floors_climbed', 0)}, descended "
                 f"{summ.get('floors_descended', 0)} (floor height {floors.floor_height_m:g} m)")
    _legend(ax, loc="upper left")
    c.save(fig, "height")


def draw_charts(stream: ChartStream, out_dir: str | Path, keys=tuple(FILES)) -> dict[str, Path]:
    """Write charts 1-7 (those of ``keys``, names of ``FILES``) from a finished ``ChartStream`` into
    ``out_dir``; returns {name: path}."""
    c = _Charts(stream, out_dir, keys)
    if "raw_imu" in keys:
        _raw_imu_chart(c)
    # 2 gravity-free acceleration, 3 velocity, 4 position vs time
    c.time_chart("acc_gravity_free", 0, ["a east", "a north", "a up"], "acceleration (m/s²)",
                 "Acceleration in the navigation frame, gravity removed", "upper right", extra=3)
    c.time_chart("velocity", 4, ["v east", "v north", "v up"], "velocity (m/s)",
                 "Velocity of the boot (zero in stance: ZUPT)", "upper right")
    c.time_chart("position", 7, ["x (east)", "y (north)", "z (up)"], "position (m)",
                 "Position vs time" + ("" if c.ref_est is None else " (dotted: reference)" if c.ref_t is not None
                                       else " (stars: the reference's end point)"), "upper left",
                 reference=c.reference_vs_time)
    _, pos, fp = stream.path_drawn()
    stats = _path_stats(c.summary, c.info["metrics"])
    if "path_2d" in keys:
        _path_2d_chart(c, pos, fp, stats)
    if "path_3d" in keys:
        _path_3d_chart(c, pos, stats)
    if "height" in keys:
        _height_chart(c)
    return c.paths


def reference_in_estimate_frame(ref_pts: np.ndarray, yaw_rad: float | None, start_n: np.ndarray) -> np.ndarray:
    """Reference points (from ``reference_path.align_to_reference``: its frame, origin at the start) in the
    estimate's nav frame: rotated by −yaw about z, moved to the estimate's start.

    Parameters
    ----------
    ref_pts : (M, 3) array
    yaw_rad : float or None
        The rotation that took the estimate onto the reference (None: none).
    start_n : (3,) array
        The estimate's first position.

    Returns
    -------
    (M, 3) array
    """
    c, s = (np.cos(yaw_rad), np.sin(yaw_rad)) if yaw_rad is not None else (1.0, 0.0)
    out = np.column_stack((c * ref_pts[:, 0] + s * ref_pts[:, 1], -s * ref_pts[:, 0] + c * ref_pts[:, 1],
                           ref_pts[:, 2]))
    return out + np.asarray(start_n, float)


#: one colour per floor (path.html, the live view): no green and no red, the colours of the start and end markers
FLOOR_COLORS = ("#1f77b4", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f")
START_COLOR, END_COLOR = "#2ca02c", "#d62728"


def _floor_color(floor_ids: list[int], k: int) -> str:
    """The colour of floor ``k`` among the walk's ``floor_ids`` (sorted)."""
    return FLOOR_COLORS[floor_ids.index(k) % len(FLOOR_COLORS)]


def _html_floors(t_drawn: np.ndarray, steps: dict) -> np.ndarray:
    """Floor of every drawn point: the ``floor`` column (steps.csv) of the last stride ending at or before it
    (0 before the first): path.html shows the floors steps.csv gives."""
    t = np.asarray(steps.get("t_s", []), float)
    fl = np.asarray(steps.get("floor", np.zeros(len(t))), np.int64)
    if len(t) == 0 or len(fl) != len(t):
        return np.zeros(len(t_drawn), dtype=np.int64)
    i = np.searchsorted(t, t_drawn, side="right") - 1
    return np.where(i >= 0, fl[np.clip(i, 0, len(fl) - 1)], 0)


def _html_strides(st: dict, st_floor: np.ndarray, r_dot: float) -> tuple[str, str, bool]:
    """path.html's marker of every stride (hover: number, time, height, floor, length, 1-σ ellipse) and, when the
    steps carry them, the strides' 1-σ ellipses: (markers SVG, ellipses SVG, whether there are ellipses)."""
    n_st = len(st["t_s"])
    has_unc = all(c in st for c in ELLIPSE_COLUMNS) and n_st > 0
    if has_unc:
        ea, eb, eo = (np.asarray(st[c], float) for c in ELLIPSE_COLUMNS)
        unc = [f", 1σ ellipse {a:.2f} m × {b_:.2f} m" for a, b_ in zip(ea, eb)]
    else:
        unc = [""] * n_st
    floor_txt = ([f", floor {int(f):+d}" for f in st["floor"]] if "floor" in st else [""] * n_st)
    dots = "".join(
        f'<circle class="stride" data-floor="{k}" cx="{x:.3f}" cy="{-y:.3f}" r="{r_dot:.3f}"><title>stride {i + 1}: '
        f't = {t:.2f} s, z = {z:+.2f} m{ft}, length {L:.2f} m{u}</title></circle>'
        for i, (t, x, y, z, L, k, ft, u) in enumerate(zip(st["t_s"], st["x_m"], st["y_m"], st["z_m"],
                                                          st["stride_length_m"], st_floor, floor_txt, unc)))
    # the 1-σ ellipse of every stride (strides.ellipse: orientation counter-clockwise from east; the page
    # draws north up, i.e. y negated, so SVG's clockwise-positive rotate() takes −θ)
    ellipses = "".join(
        f'<ellipse class="unc" data-floor="{k}" cx="{x:.3f}" cy="{-y:.3f}" rx="{a:.3f}" ry="{b_:.3f}" '
        f'transform="rotate({-np.degrees(o):.2f} {x:.3f} {-y:.3f})"/>'
        for x, y, a, b_, o, k in zip(st["x_m"], st["y_m"], ea, eb, eo, st_floor)) if has_unc else ""
    return dots, ellipses, has_unc


def _html_page(title: str, legend: str, floor_ui: str, key: str, vb: list[float], ref_svg: str, ellipses: str,
               lines: str, dots: str, r_dot: float, end_xy: np.ndarray) -> str:
    """The self-contained page of ``draw_html`` around its SVG parts: header, zoomable view, metre grid and
    scale bar (script), floor and uncertainty switches."""
    import json

    page = f"""<!DOCTYPE html><html><head><meta charset="utf-8"><title>{title}</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>html,body{{height:100%;margin:0;font-family:sans-serif}} body{{display:flex;flex-direction:column;overflow:hidden}}
header{{padding:.4em .8em}} h3{{margin:.2em 0}} header p{{margin:.2em 0;font-size:90%}}
#wrap{{position:relative;flex:1;min-height:200px}} svg#v{{position:absolute;inset:0;width:100%;height:100%;cursor:grab;
border-top:1px solid #ccc}} polyline{{fill:none;vector-effect:non-scaling-stroke}} .path{{stroke-width:2}}
#reference{{stroke:#000;stroke-width:2;stroke-dasharray:2 4}} circle.stride{{fill:#1f77b4;opacity:.8}}
circle.stride:hover{{fill:#d62728}} #grid line{{stroke:#ddd;vector-effect:non-scaling-stroke;stroke-width:1}}
#grid text{{fill:#888}} #scale{{position:absolute;left:12px;bottom:12px;background:#fffc;padding:2px 6px;font-size:13px}}
#bar{{height:6px;border:2px solid #000;border-top:none}} button{{margin-left:1em}}
ellipse.unc{{fill:#ff7f0e;fill-opacity:.08;stroke:#ff7f0e;stroke-opacity:.35;stroke-width:1;vector-effect:non-scaling-stroke}}
.key{{margin-right:1em;white-space:nowrap}} .sw{{display:inline-block;width:1.6em;height:.45em;margin-right:.3em;
vertical-align:middle}} .sw.dot{{width:.8em;height:.8em;border-radius:50%}}</style></head><body>
<header><h3>{title}</h3><p>Metres, north up (x east, y north); {legend}. Wheel = zoom, drag = pan, hover a stride
for details. {floor_ui}<button id="fit">fit</button></p><p id="key">{key}</p></header>
<div id="wrap"><svg id="v" viewBox="{' '.join(f'{v:.3f}' for v in vb)}" preserveAspectRatio="xMidYMid meet">
<g id="grid"></g>{ref_svg}<g id="uncs">{ellipses}</g>{lines}{dots}
<circle id="start" cx="0" cy="0" r="{2 * r_dot:.3f}" style="fill:{START_COLOR}"><title>start</title></circle>
<circle id="end" cx="{end_xy[0]:.3f}" cy="{-end_xy[1]:.3f}" r="{2 * r_dot:.3f}" style="fill:{END_COLOR}"><title>end</title></circle>
</svg><div id="scale"><div id="bar"></div><span id="scalelabel"></span></div></div>
<script>
const s=document.getElementById('v'),home={json.dumps(vb)},NS='http://www.w3.org/2000/svg';let b=home.slice(),d=null;
function nice(x){{const e=Math.pow(10,Math.floor(Math.log10(x))),m=x/e;return (m<1.5?1:m<3.5?2:m<7.5?5:10)*e;}}
function view(){{  // the part of the viewBox actually shown (meet: the wider side is padded)
 const r=s.getBoundingClientRect(),k=Math.max(b[2]/r.width,b[3]/r.height),w=r.width*k,h=r.height*k;
 return [b[0]-(w-b[2])/2,b[1]-(h-b[3])/2,w,h,k];}}
function draw(){{
 s.setAttribute('viewBox',b.join(' '));const [x0,y0,w,h,k]=view(),g=document.getElementById('grid');
 g.replaceChildren();const st=nice(Math.max(w,h)/8),fs=12*k;
 for(let x=Math.ceil(x0/st)*st;x<=x0+w;x+=st){{const l=document.createElementNS(NS,'line');
  l.setAttribute('x1',x);l.setAttribute('x2',x);l.setAttribute('y1',y0);l.setAttribute('y2',y0+h);g.appendChild(l);
  const t=document.createElementNS(NS,'text');t.setAttribute('x',x+fs/4);t.setAttribute('y',y0+h-fs/3);
  t.setAttribute('font-size',fs);t.textContent=+x.toFixed(6)+' m';g.appendChild(t);}}
 for(let y=Math.ceil(y0/st)*st;y<=y0+h;y+=st){{const l=document.createElementNS(NS,'line');
  l.setAttribute('x1',x0);l.setAttribute('x2',x0+w);l.setAttribute('y1',y);l.setAttribute('y2',y);g.appendChild(l);
  const t=document.createElementNS(NS,'text');t.setAttribute('x',x0+fs/4);t.setAttribute('y',y-fs/4);
  t.setAttribute('font-size',fs);t.textContent=+(-y).toFixed(6)+' m';g.appendChild(t);}}
 const m=nice(100*k);document.getElementById('bar').style.width=(m/k)+'px';
 document.getElementById('scalelabel').textContent=(m>=1?+m.toFixed(3)+' m':+(100*m).toFixed(3)+' cm');}}
s.addEventListener('wheel',e=>{{e.preventDefault();const r=s.getBoundingClientRect(),[x0,y0,w,h]=view(),
 f=e.deltaY>0?1.2:1/1.2,px=x0+(e.clientX-r.left)/r.width*w,py=y0+(e.clientY-r.top)/r.height*h;
 b=[px-(px-b[0])*f,py-(py-b[1])*f,b[2]*f,b[3]*f];draw();}});
s.addEventListener('mousedown',e=>d=[e.clientX,e.clientY]);window.addEventListener('mouseup',()=>d=null);
window.addEventListener('mousemove',e=>{{if(!d)return;const k=view()[4];
 b[0]-=(e.clientX-d[0])*k;b[1]-=(e.clientY-d[1])*k;d=[e.clientX,e.clientY];draw();}});
document.getElementById('fit').onclick=()=>{{b=home.slice();draw();}};window.addEventListener('resize',draw);
const uc=document.getElementById('unc');if(uc)uc.onchange=()=>{{document.getElementById('uncs').style.display=uc.checked?'':'none';}};
const fl=document.getElementById('floor');if(fl)fl.onchange=()=>{{for(const el of s.querySelectorAll('[data-floor]'))
 el.style.display=(fl.value==='all'||el.dataset.floor===fl.value)?'':'none';}};
draw();
</script></body></html>
"""
    return page


def make_html(result, out_dir: str | Path) -> Path:
    """``path.html`` of a whole run (``pipeline.ProcessResult``); see ``draw_html``."""
    return draw_html(ChartStream.from_result(result, time_charts=False), out_dir)


def draw_html(stream: ChartStream, out_dir: str | Path) -> Path:
    """``path.html``: the path from above as a self-contained SVG page (no network, no library), for a trainer.

    Metre grid with labels and a scale bar that follow the zoom; the reference (when given, in the estimate's
    frame) dotted; one colour per counted floor with a floor selector on multi-storey walks; start, end and
    a marker per stride (hover: stride number, time, height, floor, length, 1-σ ellipse); the 1-σ horizontal
    ellipse of every stride, shaded, with a key and a switch; wheel zooms, drag pans, "fit" (or a
    window resize) fits the whole path to the window. Equal axes (1 m east = 1 m north), north up. The path
    is the decimated one of ``ChartStream`` (``decimate.PathExtremes``), the strides all of them.
    """
    import html

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    info = stream.info
    _, t_drawn, pos = stream.path.points()
    xy = pos[:, :2]
    ref = None if info["reference"] is None else info["reference"]["est"][:, :2]
    every = np.vstack([xy, np.zeros((1, 2))] + ([ref] if ref is not None else []))
    lo, hi = every.min(axis=0), every.max(axis=0)
    pad = 0.05 * max(float((hi - lo).max()), 1.0)
    lo, hi = lo - pad, hi + pad
    r_dot = 0.006 * float((hi - lo).max())

    def points(a):  # SVG y grows downwards: plot -y so that north is up
        return " ".join(f"{x:.3f},{-y:.3f}" for x, y in a)

    level = _html_floors(t_drawn, info["steps"])
    floor_ids = sorted(set(level.tolist()))
    cuts = np.flatnonzero(np.diff(level)) + 1
    lines = []
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(xy)]):  # one polyline per run on one floor (joined)
        k = int(level[a])
        color = _floor_color(floor_ids, k)
        lines.append(f'<polyline class="path" data-floor="{k}" style="stroke:{color}" '
                     f'points="{points(xy[max(a - 1, 0):b])}"/>')
    st = info["steps"]
    n_st = len(st["t_s"])
    dots, ellipses, has_unc = _html_strides(st, level[np.minimum(np.searchsorted(t_drawn, st["t_s"]), len(level) - 1)],
                                            r_dot)
    ref_svg = (f'<polyline id="reference" points="{points(ref)}"><title>reference</title></polyline>'
               if ref is not None else "")
    summary = info["summary"]
    p = summary.get("path", {})
    title = html.escape(f"{Path(str(summary['input']['source'])).name}: {p.get('distance_m', 0):.2f} m, "
                        f"{endpoint_label(summary)} {p.get('closure_3d_m', float('nan')):.2f} m")
    floor_ui = ""
    if len(floor_ids) > 1:
        opts = "".join(f'<option value="{k}">floor {k:+d}</option>' for k in floor_ids)
        floor_ui = f'<label>floor <select id="floor"><option value="all">all floors</option>{opts}</select></label>'
    # the key: each floor's colour, then the markers
    key = "".join(f'<span class="key" data-floor="{k}"><span class="sw" style="background:{_floor_color(floor_ids, k)}">'
                  f'</span>{"start floor" if k == 0 else f"floor {k:+d}"}</span>' for k in floor_ids)
    key += (f'<span class="key"><span class="sw dot" style="background:{START_COLOR}"></span>start</span>'
            f'<span class="key"><span class="sw dot" style="background:{END_COLOR}"></span>end</span>'
            f'<span class="key"><span class="sw dot" style="background:#1f77b4;opacity:.8"></span>stride</span>')
    legend = "line = path, coloured by floor" + (", dotted = reference" if ref is not None else "")
    if has_unc:
        legend += (", shaded ellipse = 1σ horizontal uncertainty of a stride (the filter's, plus the sensor's scale "
                   "and cross-axis tolerance; 39 % inside if it is honest, 2σ = twice as large)")
        floor_ui += '<label><input type="checkbox" id="unc" checked> uncertainty</label>'
        key += ('<span class="key"><span class="sw" style="background:#ff7f0e;opacity:.35"></span>'
                '1σ uncertainty</span>')
    if "floor" in st and n_st:
        legend += f"; floor now {int(st['floor'][-1]):+d}"
    vb = [round(float(v), 3) for v in (lo[0], -hi[1], hi[0] - lo[0], hi[1] - lo[1])]  # mm, as the coordinates
    page = _html_page(title, legend, floor_ui, key, vb, ref_svg, ellipses, "".join(lines), dots, r_dot, xy[-1])
    path = out / "path.html"
    atomic.write_text(path, page)
    return path
