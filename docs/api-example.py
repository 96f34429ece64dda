"""bootnav from Python, notebook style (each ``# %%`` is a cell; run as a script, or paste into Jupyter).

Uses the repository's bundled x-io walk (a 23 m closed loop); ``tests/test_api.py`` executes this file.
Run: ``.venv/bin/python docs/api-example.py [OUTDIR]``.
"""

# %% load a recording (a bootnav .h5, or any file `bootnav import` reads: CSV, SD-card log, ...)
import sys
import tempfile
from pathlib import Path

import numpy as np

import bootnav

rec = bootnav.load(Path(__file__).resolve().parents[1] / "recordings" / "xio_ngimu_short_walk.h5")
print(f"{rec.n} samples at {rec.rate_hz:.0f} Hz, {rec.t_s[-1] - rec.t_s[0]:.1f} s")

# %% reconstruct the path; settings are keywords (any ProcessSettings field, nested ones as dicts or by name);
# every warning is also a Python warning (bootnav.errors.BootnavWarning) and in res.warnings
res = bootnav.process(rec, reference={"closed_loop": True}, detector="adaptive")
print(res)
print(f"distance {res.summary['distance_m']:.2f} m, closure {res.metrics['closure_pct']:.2f} % of it")
print("last position (m, east-north-up):", np.round(res.pos_n_m[-1], 3))
print("stride lengths (m):", np.round(res.steps["stride_length_m"], 2))

# %% the same from plain arrays (SI units, sensor frame): e.g. data from your own logger. Units are checked
# against physics (gravity at rest, gyro peaks, time step): arrays in g, deg/s or ms are an error naming the
# keyword that declares them (acc_unit="g", gyro_unit="dps", time_unit="ms")
t_s, acc_mps2, gyro_radps = rec.t_s, rec.acc_mps2, rec.gyro_radps
res_arrays = bootnav.process(t_s, acc_mps2, gyro_radps, crop_s=(0.0, 30.0))
print(res_arrays)
res_deg = bootnav.process(t_s, acc_mps2, np.degrees(gyro_radps), gyro_unit="dps", crop_s=(0.0, 30.0))

# %% tables (pandas is optional: the arrays above need none)
try:
    df = res.to_dataframe()  # indexed by t_s: x_m, y_m, z_m, vx_mps, vy_mps, vz_mps, stance, qw, qx, qy, qz
    print(df.describe().loc[["min", "max"], ["x_m", "y_m", "z_m"]])
    print(res.steps_dataframe()[["stride_length_m", "heading_deg_cw_from_north"]].head())  # indexed by t_s
    import pandas as pd  # a DataFrame in: columns t_s, ax_mps2 ... gz_radps (ax_g, gx_dps, t_ms declare units)
    frame = pd.DataFrame({"t_s": t_s, **{f"a{a}_mps2": acc_mps2[:, i] for i, a in enumerate("xyz")},
                          **{f"g{a}_radps": gyro_radps[:, i] for i, a in enumerate("xyz")}})
    print(bootnav.process(frame, crop_s=(0.0, 30.0)))
except ImportError as exc:
    print(exc)

# %% step-and-heading (PDR) for a sensor that is not on the foot (here the same foot, for the example)
steps = bootnav.pdr(t_s, acc_mps2, gyro_radps, heading="gyro")
print(steps, "- mean step", round(float(np.mean(steps.length_m)), 2), "m")  # steps.steps_dataframe(): a table

# %% write every file `bootnav process --out DIR` writes (CSV, summary.json, results.h5, charts, path.html)
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp()) / "walk"
files = res.save(out)
print("wrote", len(files), "files into", out)
