"""``calibrate``: from one or more hand-held sessions to a ``SensorCalibration`` with 1σ and residuals.

Steps (each in its own module): static poses (``static``) → accelerometer C, b [, k] from the poses
(``accel_fit``) → up directions at the pose anchors → gyro bias per motion (interpolated between the poses
around it) and gyro C from the motions and full turns (``gyro_fit``) → gyro bias [and k] stored from the poses
by linear least squares (``fit_bias_temperature``) → checks that every parameter is determined (one-line
``InputError`` naming what to add) and whether it reaches the goals (warnings).

Several sessions share C and the bias model b + k (T − T_ref); T_ref is the mean pose temperature. k is fitted
only when the poses span ``temp_span_min_degc``. Per power-on the biases also jump by the sensor's turn-on
repeatability, which two sessions cannot tell from temperature: the filter re-estimates the gyro bias at the
start of every recording anyway, so the stored gyro bias is a starting value, the scale and misalignment are
what the calibration is for.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bootnav.core.sensorcal import SensorCalibration, TriadCalibration, normalize_device_id, utc_now
from bootnav.errors import InputError

from .accel_fit import AXES, AccelFit, fit_accelerometer
from .gyro_fit import GyroData, GyroFit, axis_coverage, detect_turns, fit_gyroscope, initial_theta
from .settings import SensorCalSettings
from .static import StaticPoses, detect_static_poses

MIN_POSES = 9  # unknowns of the accelerometer model without temperature (12 with it)
# what to do to see a rotation about each sensor axis (axes as printed on the board)
ROTATE_HINT = {
    "x": "turn the boot about the sensor's x axis while it is horizontal (x along the foot: roll it onto its "
         "left and right side) at least twice",
    "y": "turn the boot about the sensor's y axis while it is horizontal (y across the foot: tip it onto its "
         "toe and its heel) at least twice",
    "z": "turn the boot about the sensor's z axis while it is horizontal (z up the leg: lay the boot on its "
         "side and turn it from sole-down towards toe-down) at least twice",
}


@dataclass
class Session:
    """One loaded session: raw SI arrays and where they came from."""

    name: str
    t_s: np.ndarray
    acc: np.ndarray
    gyro: np.ndarray
    temp_degc: np.ndarray | None
    saturated: np.ndarray | None
    device_id: str | None
    info: dict = field(default_factory=dict)
    truth: dict | None = None


@dataclass
class CalibrationResult:
    """What ``calibrate`` returns: the calibration, the poses and motions it used, residuals, warnings."""

    calibration: SensorCalibration | None  # None (and gyro None) when the accelerometer is undetermined
    accel: AccelFit
    gyro: GyroFit | None
    gyro_bias_sigma: np.ndarray
    poses: list  # StaticPoses per session
    motions: GyroData
    coverage_rad: np.ndarray  # (3,) rotation about each axis that gravity could see
    warnings: list
    settings: SensorCalSettings
    undetermined: list  # (parameter, sigma, limit, hint) of parameters above the 'undetermined' limits
    below_goal: list  # (parameter, sigma, goal) of parameters above the goals

    def fit_record(self) -> dict:
        """Residuals per pose / motion and the settings (goes into the calibration file's ``fit`` record)."""
        return {"settings": self.settings.to_dict(),
                "accelerometer_pose_residuals_mps2": self.accel.residuals.tolist(),
                "gyroscope_motion_residuals_rad": self.gyro.residual_rad.tolist(),
                "gyroscope_pose_residuals_rad": self.gyro.pose_residual_rad.tolist(),
                "gyroscope_session_bias_radps": self.gyro.bias.tolist(),
                "gyroscope_session_bias_drift_radps_per_s": self.gyro.bias_drift.tolist(),
                "turn_heading_residuals_rad": [v for v in self.gyro.turn_residual_rad.tolist() if v == v],
                "motions": list(self.motions.label)}


def session_from_recording(rec, name: str | None = None) -> Session:
    """A ``Session`` from a loaded ``bootnav.logger.recording.Recording``."""
    dev = None
    try:
        dev = normalize_device_id(rec.meta.get("device_id"))
    except (ValueError, TypeError):
        dev = None
    path = Path(rec.path) if rec.path else None
    t = np.asarray(rec.t_s, dtype=np.float64)
    temp = None if rec.temp_degc is None else np.asarray(rec.temp_degc, dtype=np.float64)
    info = {"file": path.name if path else (name or "session"), "duration_s": float(t[-1] - t[0]) if t.size else 0.0}
    if temp is not None and np.isfinite(temp).any():
        info["temp_range_degc"] = [float(np.nanmin(temp)), float(np.nanmax(temp))]
    if path is not None and path.is_file():
        h = hashlib.sha256()
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        info["sha256"] = h.hexdigest()
    return Session(name=name or (path.name if path else "session"), t_s=t,
                   acc=np.asarray(rec.acc_mps2, dtype=np.float64), gyro=np.asarray(rec.gyro_radps, dtype=np.float64),
                   temp_degc=temp, saturated=getattr(rec, "saturated", None), device_id=dev, info=info,
                   truth=getattr(rec, "truth", None))


def load_session(path: str | Path) -> Session:
    from bootnav.logger.recording import load

    rec = load(path)
    if rec.n < 10:
        raise InputError(f"{path}: only {rec.n} samples; a calibration session is 1–3 minutes of poses")
    return session_from_recording(rec)


def build_gyro_data(sessions, poses, temp_ref: float, s: SensorCalSettings) -> GyroData:
    """Concatenate the sessions and list the usable motions between consecutive poses (``gyro_fit.GyroData``).

    A motion is dropped when it lasts longer than ``max_rotation_s``, has a time gap over ``max_gap_s``, a
    saturated or non-finite sample.
    """
    ys, accs, dtemps, trel, dts, sess = [], [], [], [], [], []
    p_start, p_mid, p_stop, m_from, m_to, labels = [], [], [], [], [], []
    off = 0
    n_pose = 0
    for si, (ses, ps) in enumerate(zip(sessions, poses)):
        t = ses.t_s
        n = t.shape[0]
        ys.append(np.nan_to_num(ses.gyro))
        accs.append(np.nan_to_num(ses.acc))
        temp = np.zeros(n) if ses.temp_degc is None else np.nan_to_num(ses.temp_degc - temp_ref)
        dtemps.append(temp)
        trel.append(t - 0.5 * (t[0] + t[-1]))
        d = np.zeros(n)
        d[:-1] = np.diff(t)
        dts.append(d)
        sess.append(np.full(n, si, np.int64))
        mid = (ps.start + ps.stop) // 2
        p_start.append(ps.start + off)
        p_mid.append(mid + off)
        p_stop.append(ps.stop + off)
        bad = np.zeros(n, dtype=bool) if ses.saturated is None else np.asarray(ses.saturated) != 0
        bad |= ~np.isfinite(ses.gyro).all(axis=1) | ~np.isfinite(ses.acc).all(axis=1)
        cbad = np.concatenate([[0], np.cumsum(bad)])
        gap = np.concatenate([[0], np.cumsum(d[:-1] > s.max_gap_s), [0]])
        for i in range(len(ps) - 1):
            a, b = int(mid[i]), int(mid[i + 1])
            if t[b] - t[a] > s.max_rotation_s + 0.5 * (t[ps.stop[i] - 1] - t[ps.start[i]]
                                                     + t[ps.stop[i + 1] - 1] - t[ps.start[i + 1]]):
                continue
            if cbad[b + 1] - cbad[a] or gap[b] - gap[a]:
                continue
            m_from.append(n_pose + i)
            m_to.append(n_pose + i + 1)
            labels.append(f"{ses.name} pose {i + 1}->{i + 2} ({t[ps.stop[i] - 1] - t[0]:.1f}-"
                          f"{t[ps.start[i + 1]] - t[0]:.1f} s)")
        off += n
        n_pose += len(ps)
    cat = (lambda v, shape: np.concatenate(v) if v else np.zeros(shape))
    return GyroData(y=np.ascontiguousarray(cat(ys, (0, 3))), acc=np.ascontiguousarray(cat(accs, (0, 3))),
                    dtemp=cat(dtemps, 0), t_rel=cat(trel, 0), dt=cat(dts, 0), sess=cat(sess, 0).astype(np.int64),
                    n_sessions=len(sessions), pose_start=cat(p_start, 0).astype(np.int64),
                    pose_mid=cat(p_mid, 0).astype(np.int64), pose_stop=cat(p_stop, 0).astype(np.int64),
                    mo_from=np.asarray(m_from, np.int64), mo_to=np.asarray(m_to, np.int64),
                    turn_n=np.zeros(len(m_from), np.int64), label=labels)


def fit_bias_temperature(values: np.ndarray, temp_dev: np.ndarray | None, session=None,
                         repeatability: float = 0.0):
    """b [+ k ΔT] per axis by linear least squares over the poses' mean rates: returns (b, k, σ_b, σ_k).

    Several sessions: each has its own offset δ_s with the prior 0 ± ``repeatability`` (turn-on
    repeatability, a random effect), so k comes from the temperature changes within a power-on plus what the
    prior allows between power-ons, and b is the unit's mean. σ_b includes the repeatability (the bias of
    the next power-on).
    """
    v = np.asarray(values, dtype=np.float64)
    n = v.shape[0]
    ses = np.zeros(n, np.int64) if session is None else np.asarray(session, np.int64)
    n_ses = int(ses.max()) + 1 if n else 1
    cols = [np.ones(n)] + ([np.asarray(temp_dev, dtype=np.float64)] if temp_dev is not None else [])
    base = np.column_stack(cols)
    nb = base.shape[1]
    if n_ses > 1 and repeatability > 0:
        onehot = (ses[:, None] == np.arange(n_ses)[None]).astype(np.float64)
        # within-session scatter first (offsets free), then the prior on the offsets at that scale
        free = np.column_stack([onehot] + cols[1:])
        coef, *_ = np.linalg.lstsq(free, v, rcond=None)
        r = v - free @ coef
        s_w = np.sqrt(np.maximum((r**2).sum(axis=0) / max(n - free.shape[1], 1), 1e-30))  # per axis
        out = []
        for ax in range(3):
            lam = s_w[ax] / repeatability
            a = np.vstack([np.column_stack([base, onehot]),
                           np.column_stack([np.zeros((n_ses, nb)), lam * np.eye(n_ses)])])
            rhs = np.concatenate([v[:, ax], np.zeros(n_ses)])
            c_ax, *_ = np.linalg.lstsq(a, rhs, rcond=None)
            cov = s_w[ax] ** 2 * np.linalg.pinv(a.T @ a)
            out.append((c_ax, np.sqrt(np.maximum(np.diag(cov), 0.0))))
        b = np.array([o[0][0] for o in out])
        sb = np.sqrt(np.array([o[1][0] for o in out]) ** 2 + repeatability**2)
        k = np.array([o[0][1] for o in out]) if temp_dev is not None else np.zeros(3)
        sk = np.array([o[1][1] for o in out]) if temp_dev is not None else np.zeros(3)
        return b, k, sb, sk
    coef, *_ = np.linalg.lstsq(base, v, rcond=None)
    r = v - base @ coef
    s2 = (r**2).sum(axis=0) / max(n - nb, 1)
    sd = np.sqrt(np.outer(np.diag(np.linalg.pinv(base.T @ base)), s2))  # (params, 3)
    b, sb = coef[0], np.sqrt(sd[0] ** 2 + repeatability**2)
    k = coef[1] if temp_dev is not None else np.zeros(3)
    sk = sd[1] if temp_dev is not None else np.zeros(3)
    return b, k, sb, sk


def calibrate(sessions: list[Session], settings: SensorCalSettings | None = None,
              device_id: str | None = None, require_determined: bool = True) -> CalibrationResult:
    """Fit a ``SensorCalibration`` to one or more sessions (module docstring).

    Raises
    ------
    InputError
        One line naming the session(s) and what to add, when a parameter cannot be determined
        (``require_determined``; the guided live mode passes False and reads ``undetermined`` instead).
    """
    s = settings or SensorCalSettings()
    names = ", ".join(x.name for x in sessions)
    g = s.gravity()
    devs = {x.device_id for x in sessions if x.device_id}
    if len(devs) > 1:
        raise InputError(f"{names}: sessions come from different devices ({', '.join(sorted(devs))}); "
                         "calibrate each boot from its own sessions")
    dev = device_id or (devs.pop() if devs else None)
    poses = [detect_static_poses(x.t_s, x.acc, x.gyro, x.temp_degc, s, x.saturated) for x in sessions]
    n_poses = sum(len(p) for p in poses)
    if n_poses < MIN_POSES:
        raise InputError(f"{names}: found {n_poses} static poses (>= {s.min_pose_s:g} s still), need at least "
                         f"{MIN_POSES} (12 or more recommended): hold the boot still for 2-5 s in each of 12 or "
                         "more different orientations")
    acc_mean = np.vstack([p.acc_mean for p in poses])
    gyro_mean = np.vstack([p.gyro_mean for p in poses])
    temps = np.concatenate([p.temp_mean for p in poses])
    have_temp = bool(np.all(np.isfinite(temps)))
    temp_ref = float(np.mean(temps)) if have_temp else 25.0
    span = float(np.ptp(temps)) if have_temp else 0.0
    fit_temp = have_temp and span >= s.temp_span_min_degc
    dT = (temps - temp_ref) if fit_temp else None
    warnings: list[str] = []
    if not have_temp:
        warnings.append("no sensor temperature recorded: bias stored at an assumed 25 °C, no temperature fit")
    elif not fit_temp:
        warnings.append(f"poses span {span:.1f} °C (< {s.temp_span_min_degc:g} °C): no bias temperature "
                        "coefficient fitted; add a session at another temperature (warm or cold boot) for one")

    pose_session = np.concatenate([np.full(len(p), i, np.int64) for i, p in enumerate(poses)])
    afit = fit_accelerometer(acc_mean, g, dT, session=pose_session, repeatability_mps2=s.acc_bias_repeatability_mps2)
    acc_undetermined, _ = _check(afit, None, np.full(3, np.inf), s)
    if acc_undetermined:
        # the up directions the gyro fit needs come from the accelerometer: nothing to fit the gyro against
        if require_determined:
            raise InputError(f"{names}: {undetermined_message(acc_undetermined)}")
        return CalibrationResult(None, afit, None, None, poses, None, np.zeros(3), warnings, s,
                                 acc_undetermined + [("gyroscope", float("inf"), 0.0, acc_undetermined[0][3])], [])
    acc_sigma = {k: v for k, v in afit.sigma().items() if "session" not in k}
    acc_tri = TriadCalibration(afit.matrix, afit.bias, afit.temp_coeff, acc_sigma,
                               float(np.sqrt(np.mean(afit.residuals**2))))

    gd = build_gyro_data(sessions, poses, temp_ref if have_temp else 0.0, s)
    if gd.mo_from.size == 0:
        raise InputError(f"{names}: no usable rotation between static poses (each motion from one still pose to "
                         f"the next must be shorter than {s.max_rotation_s:g} s, without gaps or saturation): "
                         "turn the boot between the holds")
    theta0 = initial_theta(gd, gyro_mean)
    gd.turn_n = detect_turns(gd, theta0, afit, s.turn_min_rad, s.turn_max_tilt_rad)
    for k in np.flatnonzero(gd.turn_n):
        gd.label[k] += f" full turn x{int(gd.turn_n[k])}"
    cover = axis_coverage(gd, theta0, afit)
    gfit = fit_gyroscope(gd, theta0, afit, s.pose_direction_sigma_rad, s.turn_heading_sigma_rad)
    gb, gk, gsb, gsk = fit_bias_temperature(gyro_mean, dT, pose_session, s.gyro_bias_repeatability_radps)
    gsig = {k: v for k, v in gfit.sigma().items() if k.startswith("C_")}
    for i, a in enumerate(AXES):
        gsig[f"bias_{a}"] = float(gsb[i])
        if fit_temp:
            gsig[f"temp_coeff_{a}"] = float(gsk[i])
    gyro_tri = TriadCalibration(gfit.matrix, gb, gk, gsig, float(np.sqrt(np.mean(gfit.residual_rad**2))))

    temp_range = (float(temps.min()), float(temps.max())) if fit_temp else None
    cal = SensorCalibration(device_id=normalize_device_id(dev) if dev else None, acc=acc_tri, gyro=gyro_tri,
                            temp_ref_degc=temp_ref, temp_range_degc=temp_range, created_utc=utc_now(),
                            sessions=[dict(x.info) for x in sessions])
    undetermined, below_goal = _check(afit, gfit, cover, s)
    res = CalibrationResult(cal, afit, gfit, gsb, poses, gd, cover, warnings, s, undetermined, below_goal)
    if require_determined and undetermined:
        raise InputError(f"{names}: {undetermined_message(undetermined)}")
    for name, sd, goal in below_goal:
        warnings.append(f"{name}: 1σ {format_sigma(name, sd)} misses the goal {format_sigma(name, goal)}; "
                        "more poses and rotations about that axis would tighten it")
    return res


def _is_scale(name: str) -> bool:
    return name.startswith("C_") and name[2] == name[3]


def format_sigma(name: str, v: float) -> str:
    if "C_" in name and _is_scale(name.split(" ")[-1]):
        return f"{100 * v:.3g} %"
    if "C_" in name:
        return f"{math.degrees(v):.3g}°"
    return f"{v:.3g}"


def _check(afit: AccelFit, gfit: GyroFit, cover: np.ndarray, s: SensorCalSettings):
    """Parameters not determined (above the 'undetermined' limits) and those missing the goals."""
    undetermined, below = [], []
    for triad, fit in (("accelerometer", afit), ("gyroscope", gfit)):
        if fit is None:
            continue
        for name, sd in fit.sigma().items():
            if "session" in name:
                continue
            if not name.startswith("C_"):
                if triad == "accelerometer" and name.startswith("bias_") and not sd <= s.undetermined_acc_bias_sigma_mps2:
                    undetermined.append((f"{triad} {name}", sd, s.undetermined_acc_bias_sigma_mps2,
                                         _accel_hint(name[-1])))
                continue
            scale = _is_scale(name)
            lim = s.undetermined_scale_sigma if scale else s.undetermined_misalignment_sigma_rad
            goal = s.goal_scale_sigma if scale else s.goal_misalignment_sigma_rad
            if not sd <= lim:
                if triad == "accelerometer":
                    hint = _accel_hint(name[2] if scale else name[2:4])
                else:
                    hint = ROTATE_HINT[name[3]]  # column of C = rotation about that raw axis
                    if cover[AXES.index(name[3])] < math.pi:
                        hint = f"no rotation about the sensor's {name[3]} axis between static poses: {hint}"
                undetermined.append((f"{triad} {name}", sd, lim, hint))
            elif sd > goal:
                below.append((f"{triad} {name}", sd, goal))
    return undetermined, below


def _accel_hint(axes: str) -> str:
    ax = " and ".join(f"{a}" for a in axes)
    return (f"too few static poses with the sensor's {ax} axis pointing up, down and sideways: hold the boot "
            "still on its sole, upside down, on both sides, on its toe and its heel")


def undetermined_message(undetermined) -> str:
    """One line: the first undetermined parameter's hint, and how many others are undetermined."""
    name, sd, lim, hint = undetermined[0]
    others = len(undetermined) - 1
    more = f" ({others} more parameter{'s' if others > 1 else ''} undetermined)" if others else ""
    return f"cannot determine {name} (1σ {format_sigma(name, sd)} > {format_sigma(name, lim)}): {hint}{more}"


def reference_parameters(s_acc, s_gyro) -> tuple[np.ndarray, np.ndarray]:
    """The (C_acc, C_gyro) a perfect fit returns for sensors y = S x + b, in this fit's frame convention.

    S_acc⁻¹ = Q U (QR, U upper triangular with a positive diagonal): the fit's body frame is Qᵀ of the true
    one, so C_acc = U and C_gyro = Qᵀ S_gyro⁻¹. For comparing a fit with a simulator's drawn constants.
    """
    q, u = np.linalg.qr(np.linalg.inv(np.asarray(s_acc, dtype=np.float64)))
    d = np.sign(np.diag(u))
    q, u = q * d, (u.T * d).T
    return u, q.T @ np.linalg.inv(np.asarray(s_gyro, dtype=np.float64))
