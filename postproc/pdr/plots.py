"""Figures mirroring the sources' plots (matplotlib, Agg backend):

* steps.png, steps_zoom.png – the detector's processed signal with the detected steps ([NKUA2009,
                Fig. 2.2.1] green lines; [Lazarevskiy2021, Figs. 3.5–3.9] clamped magnitude / main peaks /
                steps)
* length.png  – step length per step and cumulative distance (the step-length apps of [Bayindir2014])
* heading.png – compass heading per step, deg clockwise from north ([Lazarevskiy2021, Fig. 3.10] "Heading angle")
* path.png    – local E/N path ([NKUA2009, Fig. 6.3.4], [Lazarevskiy2021, Fig. 3.11]); path_latlon.png when a
                start point is given ([Lazarevskiy2021, Fig. 3.12])
* path_gps.png – PDR path (red) and GPS track (blue) when the input has GPS fixes ([Lazarevskiy2021, Fig. 3.13])
"""

from __future__ import annotations


from pathlib import Path

import numpy as np

from bootnav.core import atomic
from bootnav.postproc.outputs import heading_columns


PLOT_FILES = ("steps.png", "steps_zoom.png", "length.png", "heading.png", "path.png", "path_latlon.png",
              "path_gps.png")


def _save(fig, path: Path) -> None:
    """Save a figure crash-safely (``core.atomic``: temporary beside it, fsync, rename) and close it."""
    atomic.replace_with(path, lambda tmp: fig.savefig(tmp, dpi=110, format=path.suffix.lstrip(".")))


def write_plots(res, out_dir) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    files = []
    tr = res.events.trace
    t0 = float(tr["t_s"][0]) if "t_s" in tr and len(tr["t_s"]) else (float(res.t_s[0]) if res.count else 0.0)

    files.append(_steps_figure(plt, res, t0, out / "steps.png", None))
    if res.count:  # a zoom on the first 15 s of walking: the sources show a few steps at a time
        files.append(_steps_figure(plt, res, t0, out / "steps_zoom.png",
                                   (res.t_s[0] - t0 - 2.0, res.t_s[0] - t0 + 15.0)))

    fig, ax = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    ax[0].plot(res.t_s - t0, res.length_m, ".-")
    ax[0].set_ylabel("step length (m)")
    ax[0].set_title(f"step length: {res.settings.length}")
    ax[1].plot(res.t_s - t0, np.cumsum(res.length_m))
    ax[1].set_ylabel("distance (m)")
    ax[1].set_xlabel("time since start (s)")
    fig.tight_layout()
    files.append(out / "length.png")
    _save(fig, files[-1])
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(10, 3.5))
    ax.plot(res.t_s - t0, heading_columns(res.yaw_enu_rad)["heading_deg_cw_from_north"], ".")
    ax.set_ylim(0, 360)
    ax.set_ylabel("heading (deg, cw from N)")
    ax.set_xlabel("time since start (s)")
    ax.set_title(f"heading: {res.heading_source}")
    fig.tight_layout()
    files.append(out / "heading.png")
    _save(fig, files[-1])
    plt.close(fig)

    if res.heading_source == "none":  # no heading: the steps keep the start bearing, which is not a path
        return files
    fig, ax = plt.subplots(figsize=(6, 6))
    ax.plot(np.r_[0.0, res.x_m], np.r_[0.0, res.y_m], "r.-", ms=3, lw=0.8)
    ax.plot([0], [0], "ks", label="start")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title(f"PDR path (heading: {res.heading_source})")
    ax.legend()
    fig.tight_layout()
    files.append(out / "path.png")
    _save(fig, files[-1])
    plt.close(fig)

    if res.lat_deg is not None:
        fig, ax = plt.subplots(figsize=(6, 6))
        lat0, lon0 = res.start_lat_lon
        ax.plot(np.r_[lon0, res.lon_deg], np.r_[lat0, res.lat_deg], "r.-", ms=3, lw=0.8)
        ax.set_xlabel("longitude (deg)")
        ax.set_ylabel("latitude (deg)")
        ax.set_title("PDR path on the map (Lazarevskiy 2021, eq. 3.3)")
        ax.ticklabel_format(useOffset=False)
        fig.tight_layout()
        files.append(out / "path_latlon.png")
        _save(fig, files[-1])
        plt.close(fig)

    if res.gps is not None:
        g = res.gps
        fig, ax = plt.subplots(figsize=(6, 6))
        ax.plot(g["gps_east_m"], g["gps_north_m"], "b.-", ms=3, lw=0.8, label="GPS")
        ax.plot(g["pdr_east_m"], g["pdr_north_m"], "r.-", ms=3, lw=0.8, label="PDR")
        ax.plot([0], [0], "ks", label="first fix")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("east of the first fix (m)")
        ax.set_ylabel("north of the first fix (m)")
        ax.set_title(f"PDR vs GPS: mean {g['mean_m']:.1f} m, final {g['final_m']:.1f} m")
        ax.legend()
        fig.tight_layout()
        files.append(out / "path_gps.png")
        _save(fig, files[-1])
        plt.close(fig)
    return files


def _steps_figure(plt, res, t0, path, xlim):
    tr = res.events.trace
    two = "magnitude_g" in tr  # [Lazarevskiy2021, Figs. 3.3-3.9]: magnitude, clamped magnitude, peaks, steps
    fig, axs = plt.subplots(2 if two else 1, 1, figsize=(12, 6 if two else 4), sharex=True)
    axs = np.atleast_1d(axs)
    if two:
        axs[0].plot(np.asarray(tr["t_s"]) - t0, tr["magnitude_g"], "b-", lw=0.5, label="|a| (g), eq. 3.1")
        axs[0].set_ylabel("g")
        axs[0].legend(loc="upper right")
    ax = axs[-1]
    if "signal" in tr:
        ax.plot(np.asarray(tr["t_s"]) - t0, tr["signal"], "k-", lw=0.6, label=tr.get("signal_label", "signal"))
    if "candidates_t_s" in tr and "signal" in tr and len(tr["candidates_t_s"]):
        ct = np.asarray(tr["candidates_t_s"])
        ax.plot(ct - t0, np.interp(ct, tr["t_s"], tr["signal"]), "x", color="0.5", ms=3, label="candidate peaks")
    if res.count:
        ax.vlines(res.t_s - t0, *ax.get_ylim(), colors="g", lw=0.8, label=f"steps ({res.count})")
    ax.set_xlabel("time since start (s)")
    axs[0].set_title(f"step detection: {res.settings.detector}")
    ax.legend(loc="upper right")
    if xlim is not None:
        for a in axs:
            a.set_xlim(*xlim)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)
    return path

