"""Files written by ``bootnav process --two-boots`` (same conventions as single-foot ``process``).

``OUT/``:

* ``left/``, ``right/``: each fused foot exactly as single-foot ``process`` writes one (``trajectory.csv``,
  ``steps.csv``, ``summary.json`` with a ``two_boots`` section, ``results.h5``, charts; ``outputs.write_outputs``),
  in the common frame (the left foot's) and on the session clock;
* ``walker.csv``: ``t_s,x_m,y_m,z_m`` of the walker (midpoint of the two feet), then ``left_x_m`` … ``right_z_m``
  (the right foot interpolated at the left foot's times);
* ``strides.csv``: ``foot,t_s,x_m,y_m,z_m,stride_length_m,dz_m,yaw_enu_rad,heading_deg_cw_from_north,
  step_width_m,floor`` (``gaitmetrics``; floor: the fused foot's on storeys), both feet in time order;
* ``two_boots.json``: the summary (each foot single and fused, walker, constraint updates, clock check, frame
  alignment, both settings objects);
* ``two_boots.h5``: groups ``/left``, ``/right`` (t_s, pos_n, vel_n, q_nb, pos_sigma_n, stance), ``/walker``
  (t_s, pos_n) and ``/strides/<foot>``, every setting as attributes;
* ``two_boots_path.png``: both feet alone (thin), both fused and the walker, from above.

Nothing is overwritten without ``force``; every file goes through a temporary name renamed over it.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from bootnav.core import atomic
from bootnav.core.conventions import CONVENTIONS, __version__
from bootnav.core.jsonio import to_jsonable
from bootnav.errors import InputError

TOP_FILES = ("walker.csv", "strides.csv", "two_boots.json", "two_boots.h5", "two_boots_path.png")


def planned(out_dir: str | Path, plots: bool) -> list[Path]:
    out = Path(out_dir)
    return [out / f for f in TOP_FILES if plots or not f.endswith(".png")]


def check_outputs(result_settings, out_dir: str | Path, inputs, force: bool) -> None:
    """Refuse before any work: an existing output without ``force``, or an output that is an input."""
    from bootnav.postproc.outputs import check_outputs as check_one, same_file

    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out} is an existing file, not a directory")
    for p in planned(out, result_settings.output.plots):
        if any(i and same_file(p, Path(i)) for i in inputs):
            raise InputError(f"{p} is an input file; choose another --out")
        if p.exists() and not force:
            raise InputError(f"{p} exists; use --force to overwrite it")
    for label in ("left", "right"):
        check_one(result_settings, out / label, list(inputs), False, force)


def fused_process_result(result, label: str):
    """The single-foot ``ProcessResult`` of ``label`` with its fused path, strides and summary."""
    from bootnav.postproc.ins.filter import NavSolution
    from bootnav.postproc.strides import path_summary
    from bootnav.postproc.summary import build_summary

    single = result.single[label]
    f = getattr(result.fused, label)
    nav = NavSolution(f.t_s, f.pos_n, f.vel_n, f.q_nb, f.acc_bias_b, f.gyro_bias_b, f.pos_sigma_n,
                      {**(getattr(single.nav, "info", {}) or {}), "stream": f.info})
    steps = {k: v for k, v in result.gait[label].items() if k != "step_width_m"}
    fused = dataclasses.replace(single, t_s=f.t_s, pos_n=f.pos_n, vel_n=f.vel_n, q_nb=f.q_nb, steps=steps, nav=nav,
                                summary={}, metrics=None)
    st = fused.settings
    stats = path_summary(f.t_s, f.pos_n, f.stance, st.floor_settings(), st.selftune.min_stride_m)
    fused.summary = build_summary(fused, stats, dict(single.summary.get("timings_s", {})))
    fused.summary["two_boots"] = {"foot": label, "fused": True, "summary_file": "../two_boots.json",
                                  "constraint": result.summary["constraint"]}
    return fused


def _csv(header: list[str], columns: list, fmts: list[str]) -> str:
    """A small CSV (one row per stride: a loop per row is fine here) as text."""
    rows = [",".join(header)]
    cols = [np.asarray(c) for c in columns]
    for i in range(len(cols[0]) if cols else 0):
        rows.append(",".join(f % c[i] if not isinstance(c[i], str) else c[i] for f, c in zip(fmts, cols)))
    return "\n".join(rows) + "\n"


def walker_columns(result) -> tuple[list[str], list[np.ndarray]]:
    fl, fr = result.fused.left, result.fused.right
    pr = np.column_stack([np.interp(fl.t_s, fr.t_s, fr.pos_n[:, j]) for j in range(3)])
    w = result.walker_pos_n
    header = ["t_s", "x_m", "y_m", "z_m", "left_x_m", "left_y_m", "left_z_m", "right_x_m", "right_y_m", "right_z_m"]
    return header, [result.walker_t_s, *w.T, *fl.pos_n.T, *pr.T]


def stride_rows(result) -> dict[str, np.ndarray]:
    """Both feet's strides in time order (``strides.csv`` columns)."""
    from bootnav.postproc.outputs import heading_columns

    parts = []
    for label in ("left", "right"):
        g = result.gait[label]
        n = len(g["t_s"])
        parts.append({"foot": np.array([label] * n, dtype=object), **{k: np.asarray(g[k]) for k in
                     ("t_s", "x_m", "y_m", "z_m", "stride_length_m", "dz_m", "yaw_enu_rad")},
                      "step_width_m": np.asarray(g["step_width_m"]), "floor": np.asarray(g["floor"])})
    rows = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    order = np.argsort(rows["t_s"], kind="stable")
    rows = {k: v[order] for k, v in rows.items()}
    h = heading_columns(rows["yaw_enu_rad"])
    out = {k: rows[k] for k in ("foot", "t_s", "x_m", "y_m", "z_m", "stride_length_m", "dz_m", "yaw_enu_rad")}
    out["heading_deg_cw_from_north"] = h["heading_deg_cw_from_north"]
    out["step_width_m"] = rows["step_width_m"]
    out["floor"] = rows["floor"]
    return out


def write_h5(result, path: Path) -> None:
    import h5py

    tmp = atomic.temporary_beside(path)
    try:
        with h5py.File(tmp, "w") as f:
            f.attrs["software"] = f"bootnav {__version__}"
            f.attrs["settings"] = result.settings.to_json(indent=None)
            f.attrs["two_boot_settings"] = json.dumps(result.two_boot.to_dict())
            f.attrs["summary"] = json.dumps(to_jsonable(result.summary))
            for k, v in CONVENTIONS.items():
                f.attrs[f"convention_{k}"] = str(v)
            for label in ("left", "right"):
                foot = getattr(result.fused, label)
                g = f.create_group(label)
                for key, unit in (("t_s", "s"), ("pos_n", "m"), ("vel_n", "m/s"), ("q_nb", "1 (wxyz)"),
                                  ("pos_sigma_n", "m")):
                    g.create_dataset(key, data=np.asarray(getattr(foot, key)), compression="gzip").attrs["units"] = unit
                g.create_dataset("stance", data=np.asarray(foot.stance, np.uint8), compression="gzip")
                s = f.create_group(f"strides/{label}")
                for key, v in result.gait[label].items():
                    s.create_dataset(key, data=np.asarray(v, float if key != "quality_flags" else np.uint8))
            w = f.create_group("walker")
            w.create_dataset("t_s", data=result.walker_t_s, compression="gzip").attrs["units"] = "s"
            w.create_dataset("pos_n", data=result.walker_pos_n, compression="gzip").attrs["units"] = "m"
        atomic.commit(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def plot_paths(result, path: Path) -> None:
    """Both feet alone (thin), fused, and the walker, from above (equal axes)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .run import single_in_common_frame

    fig, ax = plt.subplots(figsize=(8, 7))
    colors = {"left": "tab:blue", "right": "tab:red"}
    for label in ("left", "right"):
        p = single_in_common_frame(result, label)
        ax.plot(p[:, 0], p[:, 1], lw=0.6, ls=":", color=colors[label], label=f"{label} foot alone")
        f = getattr(result.fused, label).pos_n
        ax.plot(f[:, 0], f[:, 1], lw=0.8, color=colors[label], label=f"{label} foot fused")
    w = result.walker_pos_n
    ax.plot(w[:, 0], w[:, 1], lw=1.6, color="k", label="walker (fused midpoint)")
    ax.plot(w[0, 0], w[0, 1], "go", label="start")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m, left sensor's initial forward axis)")
    ax.set_ylabel("y (m)")
    cs = result.summary["constraint"]
    ax.set_title(f"two boots: {cs['active_updates']} of {cs['checks']} checks moved the feet (bound "
                 f"{cs['bound_m']:.2f} m)")
    ax.legend(loc="best", fontsize=8)
    ax.grid(True, alpha=0.3)
    tmp = atomic.temporary_beside(path)
    try:
        fig.savefig(tmp, dpi=110, format="png")
        atomic.commit(tmp, path)
    finally:
        plt.close(fig)
        tmp.unlink(missing_ok=True)


def write_two_boot_outputs(result, out_dir: str | Path, force: bool = False) -> dict[str, str]:
    """Write every file of the module docstring; returns {kind: path}."""
    from bootnav.postproc.outputs import write_csv, write_outputs

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files: dict[str, str] = {}
    for label in ("left", "right"):
        foot_files = write_outputs(fused_process_result(result, label), out / label, False, force)
        files.update({f"{label}_{k}": v for k, v in foot_files.items()})
    header, cols = walker_columns(result)
    write_csv(out / "walker.csv", tuple(header), cols, ["%.6f"] + ["%.4f"] * 9)  # the fast block writer, crash-safe
    files["walker"] = str(out / "walker.csv")
    rows = stride_rows(result)
    atomic.write_text(out / "strides.csv", _csv(list(rows), list(rows.values()),
                                           ["%s", "%.6f", "%.4f", "%.4f", "%.4f", "%.4f", "%.4f", "%.5f", "%.3f",
                                            "%.4f", "%d"]))
    files["strides"] = str(out / "strides.csv")
    write_h5(result, out / "two_boots.h5")
    files["two_boots_h5"] = str(out / "two_boots.h5")
    if result.settings.output.plots:
        plot_paths(result, out / "two_boots_path.png")
        files["two_boots_plot"] = str(out / "two_boots_path.png")
    result.summary["files"] = dict(files)
    atomic.write_text(out / "two_boots.json", json.dumps(to_jsonable(result.summary), indent=1) + "\n")
    files["summary"] = str(out / "two_boots.json")
    return files
