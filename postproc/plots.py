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

Time charts shade stance (green) and saturated intervals (red). Long signals are decimated for drawing
only, to at most ``OutputSettings.plot_max_points`` points per line: time charts keep the minimum and the
maximum of every time column (``minmax_columns``), so a one-sample peak stays visible; the path charts
take every k-th sample. Every number in the files comes from the full data.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .strides import floor_levels, floor_signal, footprints
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


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"figure.dpi": 110, "axes.grid": True, "grid.alpha": 0.3, "legend.fontsize": 8,
                         "legend.framealpha": 0.85})
    return plt


def gravity_free_acc_n(q_nb: np.ndarray, acc_b: np.ndarray, gravity: float) -> np.ndarray:
    """a_n = C_nb(q_nb) f_b + [0, 0, −g] (m/s²)."""
    from scipy.spatial.transform import Rotation

    rot = Rotation.from_quat(np.asarray(q_nb)[:, [1, 2, 3, 0]])  # scipy wants xyzw
    return rot.apply(acc_b) - np.array([0.0, 0.0, gravity])


def minmax_columns(t: np.ndarray, y: np.ndarray, n_cols: int) -> tuple[np.ndarray, np.ndarray]:
    """Decimate a time series for drawing without losing its peaks: min and max of each time column.

    Parameters
    ----------
    t : (N,) array
        Non-decreasing times, s.
    y : (N,) or (N, k) array
        The signals.
    n_cols : int
        Columns of equal duration over [t[0], t[-1]] (about the chart's width in pixels, or more).

    Returns
    -------
    (t2, y2)
        Two points per non-empty column at its mid time, its minimum then its maximum (per signal), so the
        line sweeps the column's whole range as a rasteriser would; ``t, y`` unchanged when N <= 2 n_cols.
    """
    t = np.asarray(t)
    y = np.asarray(y)
    if len(t) <= 2 * n_cols:
        return t, y
    starts = np.unique(np.searchsorted(t, np.linspace(t[0], t[-1], n_cols + 1)[:-1], side="left"))
    ends = np.r_[starts[1:], len(t)] - 1
    lo = np.minimum.reduceat(y, starts, axis=0)
    hi = np.maximum.reduceat(y, starts, axis=0)
    t_mid = 0.5 * (t[starts] + t[ends])
    y2 = np.empty((2 * len(starts),) + y.shape[1:], dtype=y.dtype)
    y2[0::2], y2[1::2] = lo, hi
    return np.repeat(t_mid, 2), y2


def _shade(ax, t, mask, color, label):
    """Shade the samples where ``mask`` is True as one background image (thousands of stance phases would
    be thousands of polygons: slow to draw and to place a legend around)."""
    if not mask.any():
        return
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    n_col = 2000  # about one column per pixel; a column is shaded if any of its samples is (max-pooling),
    # so a one-sample saturation burst stays visible
    col = np.clip(((t[mask] - t[0]) / max(t[-1] - t[0], 1e-12) * n_col).astype(int), 0, n_col - 1)
    img = np.zeros(n_col)
    img[col] = 1.0
    if color == "tab:red":  # saturation: also a thin line per burst, visible at any zoom
        for k in col[np.r_[True, np.diff(col) > 1]][:500]:
            ax.axvline(t[0] + (k + 0.5) * (t[-1] - t[0]) / n_col, color=color, lw=0.8, alpha=0.5, zorder=0.5)
    img = np.ma.masked_equal(img, 0.0)
    ylim = ax.get_ylim()  # imshow would reset the data limits to its extent
    ax.imshow(img[None, :], aspect="auto", extent=(t[0], t[-1], 0, 1), transform=ax.get_xaxis_transform(),
              cmap=ListedColormap([color]), alpha=0.13, interpolation="nearest", zorder=0)
    ax.set_ylim(ylim)
    if label:
        ax._bootnav_legend_extra = getattr(ax, "_bootnav_legend_extra", []) + [Patch(color=color, alpha=0.25, label=label)]


def _legend(ax, **kw):
    """Legend of the drawn lines plus the shading entries (images have no legend entry of their own)."""
    handles, labels = ax.get_legend_handles_labels()
    extra = getattr(ax, "_bootnav_legend_extra", [])
    ax.legend(handles + extra, labels + [p.get_label() for p in extra], **kw)


def _time_axes(ax, t, stance, sat, ylabel, first=False):
    _shade(ax, t, stance, "tab:green", "stance" if first else None)
    _shade(ax, t, sat, "tab:red", "saturated" if first else None)
    ax.set_ylabel(ylabel)
    ax.set_xlim(t[0], t[-1])


def _lines(ax, t, y, labels, colors=AXIS_COLORS):
    for k in range(y.shape[1]):
        ax.plot(t, y[:, k], color=colors[k % len(colors)], lw=0.8, label=labels[k])


def make_plots(result, out_dir: str | Path) -> dict[str, Path]:
    """Write charts 1-7 into ``out_dir``; returns {name: path}."""
    plt = _pyplot()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    max_points = max(result.settings.output.plot_max_points, 100)
    step = max(1, int(np.ceil(len(result.t_s) / max_points)))
    d = slice(None, None, step)  # path charts: every step-th sample
    t_full, stance, sat = result.t_s, result.stance, result.saturated  # shading max-pools the full masks

    def mm(y):  # time charts: min and max per column, at most max_points points per line
        return minmax_columns(t_full, y, max_points // 2)

    t = mm(t_full[:, None])[0]
    src = Path(str(result.summary["input"]["source"])).name
    paths: dict[str, Path] = {}

    def save(fig, key):
        fig.tight_layout()
        fig.savefig(out / FILES[key])
        plt.close(fig)
        paths[key] = out / FILES[key]

    # 1 raw IMU + stance
    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(10, 7), sharex=True, gridspec_kw={"height_ratios": [3, 3, 1]})
    _lines(a1, t, mm(result.acc_b)[1], ["acc x", "acc y", "acc z"])
    _time_axes(a1, t_full, stance, sat, "specific force (m/s²)", first=True)
    _legend(a1, loc="upper right", ncol=5)
    _lines(a2, t, mm(result.gyro_b)[1], ["gyro x", "gyro y", "gyro z"])
    _time_axes(a2, t_full, stance, sat, "angular rate (rad/s)")
    _legend(a2, loc="upper right", ncol=3)
    a3.plot(t, mm(stance.astype(np.int8))[1], color="k", lw=0.8)
    a3.set_ylim(-0.2, 1.2)
    a3.set_yticks([0, 1])
    a3.set_ylabel("stance")
    a3.set_xlabel("time (s)")
    a1.set_title(f"Raw IMU (body frame) with stance indicator — {src} — detector {result.summary['stance']['method']}")
    save(fig, "raw_imu")

    def time_chart(key, values, labels, ylabel, title, loc, extra=None, reference=None):
        """Charts 2-4: three nav-frame components against time, stance and saturation shaded."""
        fig, ax = plt.subplots(figsize=(10, 4.5))
        _lines(ax, t, values, labels)
        if extra is not None:
            ax.plot(t, extra, color="k", lw=0.6, alpha=0.6, label="|a|")
        if reference is not None:
            reference(ax)
        _time_axes(ax, t_full, stance, sat, ylabel, first=True)
        ax.set_xlabel("time (s)")
        ax.set_title(title)
        _legend(ax, loc=loc, ncol=6 if extra is not None else 5)
        save(fig, key)

    # 2 gravity-free acceleration, 3 velocity, 4 position vs time
    acc_n = gravity_free_acc_n(result.q_nb, result.acc_b, result.gravity_mps2)
    acc_n = mm(np.column_stack((acc_n, np.linalg.norm(acc_n, axis=1))))[1]
    time_chart("acc_gravity_free", acc_n[:, :3], ["a east", "a north", "a up"], "acceleration (m/s²)",
               "Acceleration in the navigation frame, gravity removed", "upper right", extra=acc_n[:, 3])
    time_chart("velocity", mm(result.vel_n)[1], ["v east", "v north", "v up"], "velocity (m/s)",
               "Velocity of the boot (zero in stance: ZUPT)", "upper right")
    # aligned path + reference (when given) for charts 4-7
    pos = result.pos_n
    ref_pts = ref_t = ref_est = None
    title_ref = ""
    if result.reference is not None and len(result.reference.points_n):
        from .reference import align_to_reference

        pos, ref_pts, yaw = align_to_reference(result.reference, result.t_s, result.pos_n)
        if yaw is not None:
            title_ref = f" (estimate rotated {np.degrees(yaw):+.1f}° onto the reference)"
        ref_est = reference_in_estimate_frame(ref_pts, yaw, result.pos_n[0])
        ref_t = result.reference.t_s

    def reference_vs_time(ax, offset=np.zeros(3), axes=(0, 1, 2)):
        """The reference on a time chart, in the estimate's frame: its curves when it has times, else its
        end point at the end of the recording."""
        if ref_est is None:
            return
        for k in axes:
            name = "reference" if k == axes[0] else None
            if ref_t is not None:
                inside = (ref_t >= t_full[0]) & (ref_t <= t_full[-1])
                ax.plot(ref_t[inside], ref_est[inside, k] - offset[k], ":", color=AXIS_COLORS[k] if len(axes) > 1
                        else "k", lw=1.6, label=name)
            else:
                ax.plot([t_full[-1]], [ref_est[-1, k] - offset[k]], "*", ms=11, mec="k",
                        color=AXIS_COLORS[k] if len(axes) > 1 else "k", label=name and "reference end")

    time_chart("position", mm(result.pos_n)[1], ["x (east)", "y (north)", "z (up)"], "position (m)",
               "Position vs time" + ("" if ref_est is None else " (dotted: reference)" if ref_t is not None
                                     else " (stars: the reference's end point)"), "upper left",
               reference=reference_vs_time)
    _, fp = footprints(result.t_s, pos, result.stance)
    summ = result.summary.get("path", {})
    stats = f"distance {summ.get('distance_m', 0):.2f} m"
    m = result.metrics or {}
    if "final_error_m" in m:
        stats += f", end-point error {m['final_error_m']:.2f} m"
    elif "closure_3d_m" in summ:
        stats += f", {endpoint_label(result.summary)} {summ['closure_3d_m']:.2f} m ({summ['closure_pct']:.2f} %)"
    if "deviation_error_pct" in m:
        stats += (f"\ndistance err {m['distance_error_pct']:.1f} %, deviation {m['deviation_error_pct']:.1f} %, "
                  f"height err {m['height_error_pct']:.1f} %")
    elif "stride_mae_m" in m:
        stats += (f"\nstride length MAE {m['stride_mae_m']:.3f} m vs reference, "
                  f"distance err {m['distance_error_pct']:.1f} %")

    # 5 path from above
    fig, ax = plt.subplots(figsize=(7.5, 7.5))
    ax.plot(pos[d, 0], pos[d, 1], color="tab:blue", lw=0.9, label="estimated path (boot)")
    if len(fp):
        ax.plot(fp[:, 0], fp[:, 1], ".", color="tab:blue", ms=4, label="footprints (stance)")
    if ref_pts is not None:
        ax.plot(ref_pts[:, 0], ref_pts[:, 1], ":", color="k", lw=2, label="reference path")
    ax.plot(pos[0, 0], pos[0, 1], "o", color="tab:green", ms=9, label="start")
    ax.plot(pos[-1, 0], pos[-1, 1], "s", color="tab:red", ms=8, label="end")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_title(f"Path from above{title_ref}\n{stats}", fontsize=10)
    _legend(ax, loc="upper right")
    save(fig, "path_2d")

    # 6 3-D path
    fig = plt.figure(figsize=(8, 7))
    ax = fig.add_subplot(projection="3d")
    ax.plot(pos[d, 0], pos[d, 1], pos[d, 2], color="tab:blue", lw=0.9, label="estimated path")
    if ref_pts is not None:
        ax.plot(ref_pts[:, 0], ref_pts[:, 1], ref_pts[:, 2], ":", color="k", lw=2, label="reference path")
    ax.scatter(*pos[0], color="tab:green", s=40, label="start")
    ax.scatter(*pos[-1], color="tab:red", marker="s", s=40, label="end")
    lo, hi = pos.min(axis=0), pos.max(axis=0)
    span = max(float((hi - lo).max()), 1.0)
    mid = (lo + hi) / 2
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), mid):
        setter(c - span / 2, c + span / 2)  # equal scale on all three axes
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_zlabel("z up (m)")
    ax.set_title(f"3-D path — {stats.splitlines()[0]}", fontsize=10)
    _legend(ax, loc="upper left")
    save(fig, "path_3d")

    # 7 height with floor lines
    floors = result.settings.floor_settings()
    fig, ax = plt.subplots(figsize=(10, 4.5))
    z0 = float(fp[0, 2]) if len(fp) else float(result.pos_n[0, 2])
    ax.plot(t, mm(result.pos_n[:, 2])[1] - z0, color="tab:blue", lw=0.9, label="height of the boot")
    if len(fp):
        t_fp, fp_raw = footprints(result.t_s, result.pos_n, result.stance)
        z_fp = fp_raw[:, 2] - z0
        if floors.stair_min_dz_m is not None:
            ax.plot(t_fp, floor_signal(z_fp, floors), color="tab:purple", lw=1, ls="--",
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
        ax.text(t_full[-1], k * floors.floor_height_m, f"floor {k:+d} " if k else "start floor ", va="bottom",
                ha="right", fontsize=8, color="grey")
    reference_vs_time(ax, offset=np.array([0.0, 0.0, z0]), axes=(2,))
    _time_axes(ax, t_full, stance, sat, "height above start (m)", first=True)
    ax.set_xlabel("time (s)")
    ax.set_title(f"Height vs time — floors climbed {summ.get('floors_climbed', 0)}, descended "
                 f"{summ.get('floors_descended', 0)} (floor height {floors.floor_height_m:g} m)")
    _legend(ax, loc="upper left")
    save(fig, "height")
    return paths


def reference_in_estimate_frame(ref_pts: np.ndarray, yaw_rad: float | None, start_n: np.ndarray) -> np.ndarray:
    """Reference points (from ``reference.align_to_reference``: its frame, origin at the start) in the
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


FLOOR_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22")


def _html_floors(result, step: int) -> np.ndarray:
    """Counted floor level (0 = start floor, as chart 7 and the summary count them) of every drawn sample:
    the level of the last footprint at or before it."""
    t_fp, fp = footprints(result.t_s, result.pos_n, result.stance)
    t = result.t_s[::step]
    if len(fp) == 0:
        return np.zeros(len(t), dtype=np.int64)
    floors = result.settings.floor_settings()
    levels = floor_levels(floor_signal(fp[:, 2] - fp[0, 2], floors), floors)
    return levels[np.clip(np.searchsorted(t_fp, t, side="right") - 1, 0, len(levels) - 1)]


def make_html(result, out_dir: str | Path) -> Path:
    """``path.html``: the path from above as a self-contained SVG page (no network, no library), for a trainer.

    Metre grid with labels and a scale bar that follow the zoom; the reference (when given, in the estimate's
    frame) dotted; one colour per counted floor with a floor selector on multi-storey walks; start, end and
    a marker per stride (hover: stride number, time, height, length); wheel zooms, drag pans, "fit" (or a
    window resize) fits the whole path to the window. Equal axes (1 m east = 1 m north), north up.
    """
    import html
    import json

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    step = max(1, int(np.ceil(len(result.t_s) / max(result.settings.output.plot_max_points, 100))))
    xy = result.pos_n[::step, :2]
    ref = None
    if result.reference is not None and len(result.reference.points_n):
        from .reference import align_to_reference

        _, ref_pts, yaw = align_to_reference(result.reference, result.t_s, result.pos_n)
        ref = reference_in_estimate_frame(ref_pts, yaw, result.pos_n[0])[:, :2]
    every = np.vstack([xy, np.zeros((1, 2))] + ([ref] if ref is not None else []))
    lo, hi = every.min(axis=0), every.max(axis=0)
    pad = 0.05 * max(float((hi - lo).max()), 1.0)
    lo, hi = lo - pad, hi + pad
    r_dot = 0.006 * float((hi - lo).max())

    def points(a):  # SVG y grows downwards: plot -y so that north is up
        return " ".join(f"{x:.3f},{-y:.3f}" for x, y in a)

    level = _html_floors(result, step)
    floor_ids = sorted(set(level.tolist()))
    cuts = np.flatnonzero(np.diff(level)) + 1
    lines = []
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(xy)]):  # one polyline per run on one floor (joined)
        k = int(level[a])
        color = FLOOR_COLORS[floor_ids.index(k) % len(FLOOR_COLORS)]
        lines.append(f'<polyline class="path" data-floor="{k}" style="stroke:{color}" '
                     f'points="{points(xy[max(a - 1, 0):b])}"/>')
    st = result.steps
    st_floor = level[np.minimum(np.searchsorted(result.t_s[::step], st["t_s"]), len(level) - 1)]
    dots = "".join(
        f'<circle class="stride" data-floor="{k}" cx="{x:.3f}" cy="{-y:.3f}" r="{r_dot:.3f}"><title>stride {i + 1}: '
        f't = {t:.2f} s, z = {z:+.2f} m, length {L:.2f} m</title></circle>'
        for i, (t, x, y, z, L, k) in enumerate(zip(st["t_s"], st["x_m"], st["y_m"], st["z_m"], st["stride_length_m"],
                                                   st_floor)))
    ref_svg = (f'<polyline id="reference" points="{points(ref)}"><title>reference</title></polyline>'
               if ref is not None else "")
    p = result.summary.get("path", {})
    title = html.escape(f"{Path(str(result.summary['input']['source'])).name}: {p.get('distance_m', 0):.2f} m, "
                        f"{endpoint_label(result.summary)} {p.get('closure_3d_m', float('nan')):.2f} m")
    floor_ui = ""
    if len(floor_ids) > 1:
        opts = "".join(f'<option value="{k}">floor {k:+d}</option>' for k in floor_ids)
        floor_ui = f'<label>floor <select id="floor"><option value="all">all floors</option>{opts}</select></label>'
    legend = ("blue line = path" if len(floor_ids) == 1 else "one colour per floor")
    legend += ", dots = strides, green = start, red = end" + (", dotted = reference" if ref is not None else "")
    vb = [float(lo[0]), float(-hi[1]), float(hi[0] - lo[0]), float(hi[1] - lo[1])]
    page = f"""<!DOCTYPE html><html><head><meta charset="utf-8"><title>{title}</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>html,body{{height:100%;margin:0;font-family:sans-serif}} body{{display:flex;flex-direction:column;overflow:hidden}}
header{{padding:.4em .8em}} h3{{margin:.2em 0}} header p{{margin:.2em 0;font-size:90%}}
#wrap{{position:relative;flex:1;min-height:200px}} svg#v{{position:absolute;inset:0;width:100%;height:100%;cursor:grab;
border-top:1px solid #ccc}} polyline{{fill:none;vector-effect:non-scaling-stroke}} .path{{stroke-width:2}}
#reference{{stroke:#000;stroke-width:2;stroke-dasharray:2 4}} circle.stride{{fill:#1f77b4;opacity:.8}}
circle.stride:hover{{fill:#d62728}} #grid line{{stroke:#ddd;vector-effect:non-scaling-stroke;stroke-width:1}}
#grid text{{fill:#888}} #scale{{position:absolute;left:12px;bottom:12px;background:#fffc;padding:2px 6px;font-size:13px}}
#bar{{height:6px;border:2px solid #000;border-top:none}} button{{margin-left:1em}}</style></head><body>
<header><h3>{title}</h3><p>Metres, north up (x east, y north); {legend}. Wheel = zoom, drag = pan, hover a stride
for details. {floor_ui}<button id="fit">fit</button></p></header>
<div id="wrap"><svg id="v" viewBox="{' '.join(f'{v:.3f}' for v in vb)}" preserveAspectRatio="xMidYMid meet">
<g id="grid"></g>{ref_svg}{''.join(lines)}{dots}
<circle id="start" cx="0" cy="0" r="{2 * r_dot:.3f}" style="fill:#2ca02c"><title>start</title></circle>
<circle id="end" cx="{xy[-1, 0]:.3f}" cy="{-xy[-1, 1]:.3f}" r="{2 * r_dot:.3f}" style="fill:#d62728"><title>end</title></circle>
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
const fl=document.getElementById('floor');if(fl)fl.onchange=()=>{{for(const el of s.querySelectorAll('[data-floor]'))
 el.style.display=(fl.value==='all'||el.dataset.floor===fl.value)?'':'none';}};
draw();
</script></body></html>
"""
    path = out / "path.html"
    path.write_text(page)
    return path
