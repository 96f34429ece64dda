"""Two-boot stride ellipses (issue 24): which per-foot covariance to report.

On a simulated 32 m loop of both feet (walk, three quarter-turns on the spot; default MPU6050 profile), each
foot processed alone and then fused (default ``TwoBootSettings``, the simulator's start posture). Per seed and
foot, printed (m, semi-major axis of the horizontal 1σ ellipse):

* ``reported``: the ``strides.csv`` ellipse of the last stride, and its largest over the walk
  (``run.foot_covariance``: single-foot P in the common frame + the alignment's yaw + the scale/cross-axis term);
* ``own P``: the foot's own navigator's filter covariance in the fusion at the last stride (after the
  constraint updates it took, ``active``), with and without the bound (γ = ∞): what the ellipse would be from
  the fused filter itself (no scale term);
* ``cons/own(γ=∞)``: min / median / max over strides of the conservative part (``common_frame_covariance``) over the
  γ = ∞ navigator's own: 1 = the first-order alignment term reproduces the filter's initial-yaw variance;
* ``in 1σ/2σ``: share of strides (%) whose true footprint lies inside the reported 1σ / 2σ ellipse (39.3 /
  86.5 % for a consistent 2-D Gaussian), then the same for the own-P alternative (fused navigator's P + the
  same scale term). Truth and estimate are each taken from their own start (the frames coincide in the
  simulator, as in ``bench_twoboots.py``), so the right foot's assumed start is not part of the error.

    nice -n 10 .venv/bin/python benchmarks/twoboots_ellipses.py --seeds 0 1
    nice -n 10 .venv/bin/python benchmarks/twoboots_ellipses.py --scenario mixed-walk --duration 180 --seeds 0 1 2
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np


def inside_shares(res, label, sim, single, settings) -> tuple[float, float, float, float]:
    """% of strides whose true footprint is inside the reported 1σ / 2σ ellipse, and inside the own-P one."""
    from bootnav.postproc.ellipses import stride_scale_covariance
    from bootnav.postproc.strides import ellipse, footprints, phase_ends, stride_footprints
    from bootnav.simulator.twoboots import sensor_position_n

    f = getattr(res.fused, label)
    p_true = sensor_position_n(sim)[np.arange(sim.n)[single.index]]
    _, fp = footprints(f.t_s, f.pos_n - f.pos_n[0], f.stance)
    _, fp_t = footprints(f.t_s, p_true - p_true[0], f.stance)
    keep = stride_footprints(fp, settings.selftune.min_stride_m)[1:]
    d = (fp - fp_t)[keep, :2]
    cal = getattr(single, "sensor_calibration", None)
    extra = stride_scale_covariance(f.t_s, f.pos_n, f.stance, f.q_nb, settings,
                                    cal is not None and cal.provenance.get("status") == "applied")[keep]
    e = phase_ends(f.stance)[keep]
    g = res.gait[label]
    own = ellipse(f.pos_sigma_n[e, 0] ** 2 + extra[:, 0], f.pos_sigma_n[e, 1] ** 2 + extra[:, 1],
                  f.pos_cov_en[e] + extra[:, 2])
    out = []
    for major, minor, th in ((g["ellipse_major_m"], g["ellipse_minor_m"], g["ellipse_orientation_rad"]), own):
        u = np.cos(th) * d[:, 0] + np.sin(th) * d[:, 1]
        v = -np.sin(th) * d[:, 0] + np.cos(th) * d[:, 1]
        m2 = (u / np.maximum(major, 1e-12)) ** 2 + (v / np.maximum(minor, 1e-12)) ** 2
        out += [100 * np.mean(m2 <= 1), 100 * np.mean(m2 <= 4)]
    return tuple(out)


def main(argv=None) -> None:
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.strides import ellipse, phase_ends
    from bootnav.postproc.twoboots import TwoBootSettings
    from bootnav.postproc.twoboots.run import common_frame_covariance, fuse_results
    from bootnav.simulator import custom
    from bootnav.simulator.twoboots import WalkerGeometry, simulate_two_boots, write_two_boots

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    ap.add_argument("--scenario", default="loop", help="'loop' (32 m) or a simulator scenario, e.g. mixed-walk")
    ap.add_argument("--duration", type=float, default=None, help="s, for a simulator scenario")
    args = ap.parse_args(argv)
    geo = WalkerGeometry()
    scenario = args.scenario if args.scenario != "loop" else custom(
        "loop", lambda pb: pb.stand(5).walk(10).turn_in_place(math.pi / 2).walk(6)
                  .turn_in_place(math.pi / 2).walk(10).turn_in_place(math.pi / 2).walk(6).stand(5))
    start = dict(right_start_m=(geo.step_length_m, -geo.step_width_m), right_start_frame="left-sensor")
    print("seed foot  active  reported(last,max)  own P(last)  own P γ=∞(last)  cons/own(γ=∞) min/med/max  "
          "in 1σ/2σ reported | own P+scale (%)")
    with tempfile.TemporaryDirectory() as d:
        for seed in args.seeds:
            sims = simulate_two_boots(scenario, seed=seed, geometry=geo, duration_s=args.duration)
            files = write_two_boots(sims, Path(d) / f"s{seed}.h5")
            single = {k: process(p) for k, p in zip(("left", "right"), files)}
            st = single["left"].settings
            runs = {g: fuse_results(single, st, TwoBootSettings(max_separation_m=g, **start))
                    for g in (TwoBootSettings().max_separation_m, 1e9)}
            (bound, fused), (_, free) = runs.items()
            for label in ("left", "right"):
                def own(res, extra=0.0, full=False):
                    f = getattr(res.fused, label)
                    e = phase_ends(f.stance)
                    ell = ellipse(f.pos_sigma_n[e, 0] ** 2 + extra[:, 0], f.pos_sigma_n[e, 1] ** 2 + extra[:, 1],
                                  f.pos_cov_en[e] + extra[:, 2]) if full else \
                        ellipse(f.pos_sigma_n[e, 0] ** 2, f.pos_sigma_n[e, 1] ** 2, f.pos_cov_en[e])
                    return ell if full else ell[0]
                f = getattr(free.fused, label)
                kw = {} if label == "left" else {"yaw_rad": free.heading["yaw_rad"],
                                                 "yaw_sigma_rad": TwoBootSettings().heading_alignment_sigma_rad}
                cons = ellipse(*common_frame_covariance(f, single[label], st, **kw).T)[0]
                r = cons / own(free)
                g = fused.gait[label]["ellipse_major_m"]
                inside = inside_shares(fused, label, sims[label], single[label], st)
                print(f"{seed:4d} {label:5s} {fused.fused.n_active:6d}  {g[-1]:8.3f} {g.max():8.3f}  "
                      f"{own(fused)[-1]:10.3f}  {own(free)[-1]:14.3f}   {r.min():.3f} / {np.median(r):.3f} / "
                      f"{r.max():.3f}   {inside[0]:.0f}/{inside[1]:.0f} | {inside[2]:.0f}/{inside[3]:.0f}")


if __name__ == "__main__":
    main()
