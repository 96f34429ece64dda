"""Two-boot stride ellipses (issue 24): which per-foot covariance to report.

On a simulated 32 m loop of both feet (walk, three quarter-turns on the spot; default MPU6050 profile), each
foot processed alone and then fused (default ``TwoBootSettings``, the simulator's start posture). Per seed and
foot, printed (m, semi-major axis of the horizontal 1σ ellipse):

* ``reported``: the ``strides.csv`` ellipse of the last stride, and its largest over the walk
  (``run.foot_covariance``: single-foot P in the common frame + the alignment's yaw + the scale/cross-axis term);
* ``own P``: the foot's own navigator's filter covariance in the fusion at the last stride (after the
  constraint updates it took, ``active``), with and without the bound (γ = ∞): what the ellipse would be from
  the fused filter itself (no scale term);
* ``cons/own(γ=∞)``: min / median / max over strides of the conservative filter part (no scale term) over the
  γ = ∞ navigator's own: 1 = the first-order alignment term reproduces the filter's initial-yaw variance.

    nice -n 10 .venv/bin/python benchmarks/twoboots_ellipses.py --seeds 0 1
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import tempfile
from pathlib import Path

import numpy as np


def main(argv=None) -> None:
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.strides import ellipse, phase_ends
    from bootnav.postproc.twoboots import TwoBootSettings
    from bootnav.postproc.twoboots.run import foot_covariance, fuse_results
    from bootnav.simulator import custom
    from bootnav.simulator.twoboots import WalkerGeometry, simulate_two_boots, write_two_boots

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    args = ap.parse_args(argv)
    geo = WalkerGeometry()
    loop = custom("loop", lambda pb: pb.stand(5).walk(10).turn_in_place(math.pi / 2).walk(6)
                  .turn_in_place(math.pi / 2).walk(10).turn_in_place(math.pi / 2).walk(6).stand(5))
    start = dict(right_start_m=(geo.step_length_m, -geo.step_width_m), right_start_frame="left-sensor")
    print("seed foot  active  reported(last,max)  own P(last)  own P γ=∞(last)  cons/own(γ=∞) min/med/max")
    with tempfile.TemporaryDirectory() as d:
        for seed in args.seeds:
            files = write_two_boots(simulate_two_boots(loop, seed=seed, geometry=geo), Path(d) / f"s{seed}.h5")
            single = {k: process(p) for k, p in zip(("left", "right"), files)}
            st = single["left"].settings
            st0 = dataclasses.replace(st, ellipse_scale_sigma=0.0, ellipse_cross_axis_rad=0.0,
                                      ellipse_calibrated_sigma=0.0)
            runs = {g: fuse_results(single, st, TwoBootSettings(max_separation_m=g, **start))
                    for g in (TwoBootSettings().max_separation_m, 1e9)}
            (bound, fused), (_, free) = runs.items()
            for label in ("left", "right"):
                def own(res):
                    f = getattr(res.fused, label)
                    e = phase_ends(f.stance)
                    return ellipse(f.pos_sigma_n[e, 0] ** 2, f.pos_sigma_n[e, 1] ** 2, f.pos_cov_en[e])[0]
                f = getattr(free.fused, label)
                kw = {} if label == "left" else {"yaw_rad": free.heading["yaw_rad"],
                                                 "yaw_sigma_rad": TwoBootSettings().heading_alignment_sigma_rad}
                c = foot_covariance(f, single[label], st0, **kw)
                e = phase_ends(f.stance)
                sig, x = c["pos_sigma_n"][e], c["cov_extra"]
                cons = ellipse(sig[:, 0] ** 2 + x[:, 0], sig[:, 1] ** 2 + x[:, 1], c["pos_cov_en"][e] + x[:, 2])[0]
                r = cons / own(free)
                g = fused.gait[label]["ellipse_major_m"]
                print(f"{seed:4d} {label:5s} {fused.fused.n_active:6d}  {g[-1]:8.3f} {g.max():8.3f}  "
                      f"{own(fused)[-1]:10.3f}  {own(free)[-1]:14.3f}   {r.min():.3f} / {np.median(r):.3f} / "
                      f"{r.max():.3f}")


if __name__ == "__main__":
    main()
