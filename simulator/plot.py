"""One-page figure of a simulated recording: truth path and the synthesised signals."""

from __future__ import annotations

import numpy as np

from bootnav.core import atomic
from bootnav.simulator.simulate import SimResult


def _format(path) -> str:
    """The image format named by ``path``'s suffix (the temporary file beside it has none), PNG by default."""
    from pathlib import Path

    return Path(path).suffix.lstrip(".").lower() or "png"


def plot_result(res: SimResult, path, zoom_s: tuple[float, float] | None = None) -> None:
    """Top view + height of the truth path, and acc / gyro (truth and as delivered) with stance shaded."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tr = res.truth
    if "pose_index" in tr:
        return _plot_calibration(res, path, plt)
    t = tr["t_s"]
    pos = tr["pos_n_m"]
    fig = plt.figure(figsize=(14, 11), constrained_layout=True)
    gs = fig.add_gridspec(4, 2)
    ax = fig.add_subplot(gs[0:2, 0])
    sc = ax.scatter(pos[:, 0], pos[:, 1], c=pos[:, 2], s=1, cmap="viridis")
    fig.colorbar(sc, ax=ax, label="height z (m)")
    ax.set_aspect("equal")
    ax.set(xlabel="east x (m)", ylabel="north y (m)", title=f"{res.scenario}: truth path (sensor), top view")
    ax = fig.add_subplot(gs[0, 1])
    ax.plot(t, pos[:, 2], lw=1)
    ax.set(xlabel="t (s)", ylabel="z (m)", title="truth height")
    ax = fig.add_subplot(gs[1, 1])
    ax.plot(t, np.linalg.norm(tr["vel_n_mps"], axis=1), lw=0.8)
    ax.set(xlabel="t (s)", ylabel="|v| (m/s)", title="truth speed of the sensor")
    if zoom_s is None:
        mid = np.flatnonzero(np.diff(res.steps["dz_m"] != 0))
        t0 = res.steps["t_start_s"][mid[0] + 1] - 0.5 if mid.size else t[0]
        zoom_s = (t0, t0 + 4.0)
    m = (t >= zoom_s[0]) & (t <= zoom_s[1])
    acc_si, gyro_si = res.acc_mps2, res.gyro_radps
    for row, (name, true, meas, unit, k) in enumerate(
        (("specific force", tr["f_b_mps2"], acc_si, "m/s^2", 1.0),
         ("angular rate", tr["omega_b_radps"], gyro_si, "deg/s", 180 / np.pi)), start=2):
        for col, sel in enumerate((slice(None), m)):
            ax = fig.add_subplot(gs[row, col])
            for a, color in zip(range(3), ("C0", "C1", "C2")):
                ax.plot(t[sel], meas[sel, a] * k, color=color, lw=0.6, label=f"{'xyz'[a]} delivered")
                if col == 1:
                    ax.plot(t[sel], true[sel, a] * k, color=color, lw=1.2, ls="--", alpha=0.7)
            st = tr["stance"][sel] == 1
            ax.fill_between(t[sel], 0, 1, where=st, transform=ax.get_xaxis_transform(), color="0.85", zorder=0)
            ax.set(xlabel="t (s)", ylabel=unit, title=f"{name} (body){' - zoom, dashed = truth' if col else ''}")
            if col == 0:
                ax.legend(loc="upper right", fontsize=7, ncol=3)
    fig.suptitle(f"bootnav simulate: {res.scenario}, seed {res.seed}, profile {res.profile.name}, "
                 f"{res.rate_hz:g} Hz, mount {res.mount.name} (grey = stance)")
    atomic.replace_with(path, lambda tmp: fig.savefig(tmp, dpi=90, format=_format(path)))  # never half written
    plt.close(fig)


def _plot_calibration(res: SimResult, path, plt) -> None:
    """Hand-held calibration session: attitude, |f| and |omega| delivered, held poses shaded."""
    from bootnav.core.rotations import euler_zyx_from_quat

    tr = res.truth
    t = tr["t_s"]
    held = tr["pose_index"] >= 0
    fig, axes = plt.subplots(4, 1, figsize=(14, 11), sharex=True, constrained_layout=True)
    rpy = np.degrees(np.unwrap(euler_zyx_from_quat(tr["q_nb"]), axis=0))
    acc, gyro = res.acc_mps2, res.gyro_radps
    panels = ((rpy, ("roll", "pitch", "yaw"), "deg", "truth attitude (ZYX Euler, unwrapped)"),
              (acc, tuple("xyz"), "m/s^2", "specific force delivered"),
              (np.degrees(gyro), tuple("xyz"), "deg/s", "angular rate delivered"),
              (np.column_stack([np.linalg.norm(acc, axis=1), np.linalg.norm(tr["f_b_mps2"], axis=1)]),
               ("|f| delivered", "|f| truth"), "m/s^2", "norm of the specific force"))
    for ax, (y, labels, unit, title) in zip(axes, panels):
        for k, label in enumerate(labels):
            ax.plot(t, y[:, k], lw=0.7, label=label)
        ax.fill_between(t, 0, 1, where=held, transform=ax.get_xaxis_transform(), color="0.88", zorder=0)
        ax.set(ylabel=unit, title=title)
        ax.legend(loc="upper right", fontsize=7, ncol=3)
    axes[-1].set(xlabel="t (s)")
    fig.suptitle(f"bootnav simulate: {res.scenario}, seed {res.seed}, profile {res.profile.name} "
                 f"(grey = pose held)")
    atomic.replace_with(path, lambda tmp: fig.savefig(tmp, dpi=80, format=_format(path)))
    plt.close(fig)
