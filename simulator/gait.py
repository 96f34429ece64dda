"""Boot kinematics: a path is a sequence of strides (foot pose on the floor -> next foot pose).

One stride of the instrumented boot, period ``T = 120 / cadence`` (cadence in steps/min, both feet):

1. **stance** ``T_still = still_fraction * T``: the foot is flat and exactly still;
2. **toe-off roll** ``[0, t_to]``: the heel lifts, the foot rotates nose-down about the toe (or about
   the heel when ``toe_off_pitch_deg > 0``) to pitch ``theta_to`` with rate ``omega_to``;
3. **swing** ``[t_to, t_hs]``: a mid-swing knot (clearance above the higher floor level, peak forward
   speed) and, just before heel strike, an **impact** knot: the landing point ``impact_lead_s``
   before contact still moves down at ``impact_speed_mps``, so the deceleration to zero at contact
   gives the heel-strike shock (large for running). Yaw turns here (minimum-jerk) while airborne;
4. **heel rocker** ``[t_hs, T_m]``: the foot rotates about the heel (toe when landing toe-first) from
   ``theta_hs`` down to flat at the stride's end pose.

Rocker knots come from the exact pivot kinematics in the sagittal plane (u forward along the stride
chord, z up, theta nose-up = -pitch): with pivot G on the floor and c the pivot in foot coordinates,

    p = G - R(theta) c,  v = -R'(theta) c theta',  a = -(R''(theta) c theta'^2 + R'(theta) c theta''),

R(theta) = [[cos, -sin], [sin, cos]], R' its derivative, R'' = -R. Between knots the curve is the
piecewise septic of ``trajectory.py`` (C3, exact derivatives), so the synthesised IMU is exact.

**Crawling** (a gait with ``rest_pitch_deg > 0``, [Patrick2009]): on hands and knees the shin lies near the
floor and the boot rests on its toe, the sole flexed at the ball, the rigid rear of the boot (which carries
the sensor) pitched toe-down by ``beta_r = rest_pitch_deg`` about the ball point B = origin + toe_m e(psi,
beta), e = [cos psi cos beta, sin psi cos beta, -sin beta] (the foot's x axis). A crawl stride keeps that
posture at both ends: still for ``still_fraction * T``, then over the drag ``t_m`` (tau = t / t_m) the ball
slides forward and lifts slightly while the foot pitches and rolls a little,

    B(t) = B0 + (B1 - B0) S(tau) + [0, 0, clearance_m] H(tau),
    beta(t) = beta_r + swing_pitch_deg H(tau),   phi(t) = roll_amplitude_deg H(tau),   psi = psi0 + turn S(tau),
    origin(t) = B(t) - toe_m e(psi(t), beta(t)),
    S = 35 tau^4 - 84 tau^5 + 70 tau^6 - 20 tau^7 (rest to rest),   H = 256 tau^4 (1 - tau)^4 (a bump, peak 1),

both with zero first to third derivatives at the ends, so the curve stays C3. Going down to the knees
(``kneel``) rotates the flat foot about the fixed ball to ``beta_r``; getting up (``stand_up``) brings the
foot forward from the toe back to flat. The knots sample these curves with their exact derivatives
(products and sines of Taylor jets).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from bootnav.simulator.trajectory import CHANNELS, Trajectory, hermite_coefficients, poly_eval

X, Y, Z, YAW, PITCH, ROLL = range(6)


@dataclass(frozen=True)
class Gait:
    """One gait pattern. Angles in degrees, rates in deg/s, lengths in m (documented defaults: walking)."""

    name: str = "walk"
    stride_length_m: float = 1.40  # default horizontal foot displacement per stride
    cadence_spm: float = 110.0  # steps per minute (both feet); stride period = 120 / cadence
    still_fraction: float = 0.28  # share of the stride period the foot is flat and still
    toe_off_fraction: float = 0.16  # end of the toe-off roll, share of the moving part
    heel_strike_fraction: float = 0.86  # contact, share of the moving part
    mid_swing_fraction: float = 0.50  # where in the swing the clearance knot sits
    mid_swing_progress: float | None = None  # share of the swing's forward distance at that knot;
    # None: the natural smooth (septic) transition from the toe-off to the impact state
    clearance_m: float = 0.12  # height of the foot origin above the higher floor at mid-swing
    toe_off_pitch_deg: float = -35.0  # nose-down at toe-off (negative: rotation about the toe)
    toe_off_rate_dps: float = -200.0
    heel_strike_pitch_deg: float = 15.0  # nose-up at contact (positive: rotation about the heel)
    heel_strike_rate_dps: float = -200.0
    swing_peak_speed_ratio: float = 1.4  # mid-swing forward speed / mean swing speed (with mid_swing_progress)
    impact_speed_mps: float = 0.25  # downward speed of the landing point just before contact
    impact_lead_s: float = 0.030
    roll_amplitude_deg: float = 3.0  # small inversion during swing so all three gyro axes move
    toe_m: float = 0.15  # toe (ball) pivot ahead of the foot origin
    heel_m: float = -0.07  # heel pivot behind the foot origin
    # crawling only (rest_pitch_deg > 0): the foot rests on its toe, pitched toe-down; the drag uses
    # stride_length_m, cadence_spm, still_fraction, clearance_m (lift of the ball), roll_amplitude_deg
    rest_pitch_deg: float = 0.0  # toe-down pitch at rest (0: flat on the sole, walking)
    swing_pitch_deg: float = 0.0  # pitch change at mid-drag (negative: less toe-down)

    @property
    def period_s(self) -> float:
        return 120.0 / self.cadence_spm

    @property
    def crawl(self) -> bool:
        """True when the foot rests on its toe (hands-and-knees crawling), not flat on the sole."""
        return self.rest_pitch_deg > 0

    def validate(self) -> None:
        if not (self.cadence_spm > 0 and self.stride_length_m >= 0):
            raise ValueError(f"gait {self.name}: cadence must be > 0 and stride length >= 0")
        if not (0 <= self.still_fraction < 1):
            raise ValueError(f"gait {self.name}: still_fraction must be in [0, 1)")
        if not (0 <= self.rest_pitch_deg <= 90 and 0 <= self.rest_pitch_deg + self.swing_pitch_deg <= 90):
            raise ValueError(f"gait {self.name}: rest pitch (and rest + swing pitch) must be in [0, 90] deg")
        if self.crawl:
            return
        f = (self.toe_off_fraction, self.heel_strike_fraction)
        if not (0 < f[0] < f[1] < 1):
            raise ValueError(f"gait {self.name}: need 0 < toe_off_fraction < heel_strike_fraction < 1")
        t_m = self.period_s * (1 - self.still_fraction)
        swing = (f[1] - f[0]) * t_m
        if self.impact_lead_s >= swing * (1 - self.mid_swing_fraction):
            raise ValueError(f"gait {self.name}: impact_lead_s must end after mid-swing")


WALK = Gait()
SHUFFLE = Gait(
    "shuffle", stride_length_m=0.35, cadence_spm=100, still_fraction=0.25, clearance_m=0.03, toe_off_fraction=0.22,
    heel_strike_fraction=0.82,
    toe_off_pitch_deg=-8, toe_off_rate_dps=-40, heel_strike_pitch_deg=4, heel_strike_rate_dps=-50,
    impact_speed_mps=0.05, roll_amplitude_deg=1.0,
)
RUN = Gait(
    "run", stride_length_m=2.6, cadence_spm=170, still_fraction=0.10, toe_off_fraction=0.18,
    heel_strike_fraction=0.88, clearance_m=0.20, toe_off_pitch_deg=-55, toe_off_rate_dps=-400,
    heel_strike_pitch_deg=20, heel_strike_rate_dps=-500, impact_speed_mps=0.9, impact_lead_s=0.025,
    roll_amplitude_deg=5.0,
)
STAIRS_UP = Gait(
    "stairs_up", stride_length_m=0.56, cadence_spm=90, still_fraction=0.35, clearance_m=0.06, mid_swing_progress=0.3,
    toe_off_pitch_deg=-25, toe_off_rate_dps=-100, heel_strike_pitch_deg=4, heel_strike_rate_dps=-60,
    impact_speed_mps=0.2, roll_amplitude_deg=2.0,
)
STAIRS_DOWN = Gait(
    "stairs_down", stride_length_m=0.56, cadence_spm=95, still_fraction=0.35, clearance_m=0.07, mid_swing_progress=0.7,
    toe_off_pitch_deg=-15, toe_off_rate_dps=-80, heel_strike_pitch_deg=-8, heel_strike_rate_dps=60,
    impact_speed_mps=0.35, roll_amplitude_deg=2.0,
)
TURN = replace(SHUFFLE, name="turn", stride_length_m=0.10)
CRAWL = Gait(
    "crawl", stride_length_m=0.30, cadence_spm=60, still_fraction=0.55, clearance_m=0.015, rest_pitch_deg=75.0,
    swing_pitch_deg=-15.0, roll_amplitude_deg=3.0,
)
FAST = Gait(
    "fast", stride_length_m=2.5, cadence_spm=150, still_fraction=0.17, toe_off_fraction=0.18,
    heel_strike_fraction=0.88, clearance_m=0.16, toe_off_pitch_deg=-50, toe_off_rate_dps=-450,
    heel_strike_pitch_deg=22, heel_strike_rate_dps=-450, impact_speed_mps=0.6, impact_lead_s=0.025,
    roll_amplitude_deg=4.0,
)
GAITS = {g.name: g for g in (WALK, SHUFFLE, RUN, STAIRS_UP, STAIRS_DOWN, TURN, CRAWL, FAST)}
# per-stride kind codes: the gaits, then the two posture changes between walking and crawling
GAIT_CODES = {name: i for i, name in enumerate((*GAITS, "kneel", "stand_up"))}


def _profile(p0, v0, a0, p1, v1, a1, T, t):
    """Value, d1, d2, d3 at time t in [0, T] of the septic with the given ends (zero jerk at both ends)."""
    c = hermite_coefficients(np.array([0.0, T]), np.array([[[p0, v0, a0, 0.0]], [[p1, v1, a1, 0.0]]]))
    return tuple(float(x[0, 0]) for x in poly_eval(c, np.array([[t / T]]), np.array(T), 3))


def _pivot(G, c, th, dth, ddth, dddth=0.0, dG=(0.0, 0.0)):
    """Origin (u, z) and its first three derivatives for a foot rotating by theta about pivot G.

    p = G - R c;  p' = G' - R' c th';  p'' = R c th'^2 - R' c th'';
    p''' = R' c th'^3 + 3 R c th' th'' - R' c th'''   (R'' = -R, R''' = -R'; G moves uniformly)
    """
    s, co = math.sin(th), math.cos(th)
    Rc = np.array([co * c[0] - s * c[1], s * c[0] + co * c[1]])
    dRc = np.array([-s * c[0] - co * c[1], co * c[0] - s * c[1]])
    p = np.asarray(G, float) - Rc
    v = np.asarray(dG, float) - dRc * dth
    a = Rc * dth**2 - dRc * ddth
    j = dRc * dth**3 + 3 * Rc * dth * ddth - dRc * dddth
    return p, v, a, j


def _min_jerk(t, t0, t1, y0, y1):
    """Minimum-jerk transition y0 -> y1 over [t0, t1]: value, d1, d2, d3 (constant outside)."""
    if t <= t0 or t1 <= t0:
        return (y0 if t <= t0 else y1), 0.0, 0.0, 0.0
    if t >= t1:
        return y1, 0.0, 0.0, 0.0
    T = t1 - t0
    s = (t - t0) / T
    d = y1 - y0
    return (y0 + d * (10 * s**3 - 15 * s**4 + 6 * s**5), d * (30 * s**2 - 60 * s**3 + 30 * s**4) / T,
            d * (60 * s - 180 * s**2 + 120 * s**3) / T**2, d * (60 - 360 * s + 360 * s**2) / T**3)


# rest-to-rest ramp S and bump H on tau in [0, 1] (zero first to third derivatives at both ends)
_RAMP = np.polynomial.Polynomial([0, 0, 0, 0, 35, -84, 70, -20])
_BUMP = 256 * np.polynomial.Polynomial([0, 0, 0, 0, 1]) * np.polynomial.Polynomial([1, -1]) ** 4


def _jet(poly: np.polynomial.Polynomial, tau: float, T: float) -> np.ndarray:
    """Value and first three time derivatives of ``poly(t / T)`` at ``t = tau T``."""
    return np.array([poly.deriv(n)(tau) / T**n if n else poly(tau) for n in range(4)])


def _jet_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Product of two jets (value, d1, d2, d3) by the Leibniz rule."""
    return np.array([a[0] * b[0], a[1] * b[0] + a[0] * b[1], a[2] * b[0] + 2 * a[1] * b[1] + a[0] * b[2],
                     a[3] * b[0] + 3 * a[2] * b[1] + 3 * a[1] * b[2] + a[0] * b[3]])


def _jet_sin_cos(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """sin and cos of a jet (value, d1, d2, d3), by the chain rule."""
    s, c = math.sin(x[0]), math.cos(x[0])
    x1, x2, x3 = x[1], x[2], x[3]
    return (np.array([s, c * x1, -s * x1**2 + c * x2, -c * x1**3 - 3 * s * x1 * x2 + c * x3]),
            np.array([c, -s * x1, -c * x1**2 - s * x2, s * x1**3 - 3 * c * x1 * x2 - s * x3]))


def _toe_axis(yaw: float, pitch: float) -> np.ndarray:
    """The foot's x axis (heel to toe) in the navigation frame for ZYX yaw and pitch (roll leaves it alone)."""
    return np.array([math.cos(yaw) * math.cos(pitch), math.sin(yaw) * math.cos(pitch), -math.sin(pitch)])


@dataclass
class PathBuilder:
    """Build a foot trajectory from stand periods and strides; the foot starts flat at the origin.

    ``stride(length, dz, turn)`` moves the foot by ``length`` (horizontal, along the chord heading,
    default current yaw + turn / 2), ``dz`` up, and turns it by ``turn`` rad during the swing. ``pos`` is the
    foot origin at rest; ``pitch`` the rest pitch (0 standing, > 0 on the toe while crawling).
    """

    yaw0_rad: float = 0.0
    t: float = 0.0
    pos: np.ndarray = field(default_factory=lambda: np.zeros(3))
    yaw: float = 0.0
    pitch: float = 0.0
    _t: list = field(default_factory=list)
    _k: list = field(default_factory=list)
    steps: list = field(default_factory=list)
    gaits: dict = field(default_factory=dict)  # Gait -> index (per-step column ``gait``)

    def __post_init__(self):
        self.yaw = self.yaw0_rad
        self._append(0.0, self._rest())

    # -- knots -------------------------------------------------------------------------------
    def _rest(self) -> np.ndarray:
        k = np.zeros((6, 4))
        k[X, 0], k[Y, 0], k[Z, 0], k[YAW, 0], k[PITCH, 0] = *self.pos, self.yaw, self.pitch
        return k

    def _append(self, t: float, knot: np.ndarray) -> None:
        if self._t and t <= self._t[-1] + 1e-9:
            raise ValueError(f"knot at t={t} not after {self._t[-1]}")
        self._t.append(float(t))
        self._k.append(knot)

    # -- segments ----------------------------------------------------------------------------
    def stand(self, duration_s: float) -> "PathBuilder":
        """Keep the foot still (flat, or on its toe while crawling) for ``duration_s``."""
        if duration_s > 0:
            self.t += duration_s
            self._append(self.t, self._rest())
        return self

    def stride(self, length_m: float, dz_m: float = 0.0, turn_rad: float = 0.0, gait: Gait = WALK,
               chord_heading_rad: float | None = None) -> "PathBuilder":
        gait.validate()
        chi = self.yaw + turn_rad / 2.0 if chord_heading_rad is None else chord_heading_rad
        if gait.crawl:
            return self._crawl_stride(length_m, dz_m, turn_rad, gait, chi)
        if self.pitch:
            raise ValueError(f"a {gait.name} stride needs the foot flat: stand_up() after crawling")
        T = gait.period_s
        t_still = gait.still_fraction * T
        t_m = T - t_still
        self.stand(t_still)
        t0 = self.t
        t_to, t_hs = gait.toe_off_fraction * t_m, gait.heel_strike_fraction * t_m
        t_mid = t_to + gait.mid_swing_fraction * (t_hs - t_to)
        t_imp = t_hs - gait.impact_lead_s
        L, dz = float(length_m), float(dz_m)
        toe, heel = np.array([gait.toe_m, 0.0]), np.array([gait.heel_m, 0.0])
        th_to, w_to = math.radians(gait.toe_off_pitch_deg), math.radians(gait.toe_off_rate_dps)
        th_hs, w_hs = math.radians(gait.heel_strike_pitch_deg), math.radians(gait.heel_strike_rate_dps)
        c_to = toe if th_to <= 0 else heel
        c_hs = heel if th_hs >= 0 else toe
        G_to = c_to.copy()  # pivot on the start floor (u, z)
        G_hs = np.array([L + c_hs[0], dz])
        nan = float("nan")  # jerk left open: filled in build() from neighbouring accelerations
        sag = []  # (t, (u, du, ddu, dddu), (z, ...), (theta, ...))
        for t in (t_to / 3, 2 * t_to / 3, t_to):  # toe-off roll
            th = _profile(0, 0, 0, th_to, w_to, 0, t_to, t)
            p, v, a, j = _pivot(G_to, c_to, *th)
            sag.append((t, (p[0], v[0], a[0], j[0]), (p[1], v[1], a[1], j[1]), th))
        p_hs, v_hs, a_hs, _ = _pivot(G_hs, c_hs, th_hs, w_hs, 0.0)
        # impact knot: the landing pivot still travels (forward, down) before contact
        d = gait.impact_lead_s
        v_land = np.array([0.5 * gait.impact_speed_mps, -gait.impact_speed_mps])
        p_imp, v_imp, _, _ = _pivot(G_hs - v_land * d, c_hs, th_hs - w_hs * d, w_hs, 0.0, dG=v_land)
        u_to = sag[-1][1][0]
        z_top = max(0.0, dz) + gait.clearance_m
        mean_speed = (p_imp[0] - u_to) / (t_imp - t_to)
        u_to_state = sag[-1][1][:3]
        # pitch (and by default forward progress) at mid-swing: the smooth transition between the
        # toe-off state and the impact state, sampled with its exact derivatives
        th_mid = _profile(th_to, w_to, 0.0, th_hs - w_hs * gait.impact_lead_s, w_hs, 0.0, t_imp - t_to, t_mid - t_to)
        if gait.mid_swing_progress is None:
            u_mid = _profile(*u_to_state, p_imp[0], v_imp[0], 0.0, t_imp - t_to, t_mid - t_to)
        else:
            u_mid = (u_to + gait.mid_swing_progress * (p_imp[0] - u_to), gait.swing_peak_speed_ratio * mean_speed,
                     0.0, nan)
        sag.append((t_mid, u_mid, (z_top, 0.0, 0.0, nan), th_mid))
        sag.append((t_imp, (p_imp[0], v_imp[0], 0.0, nan), (p_imp[1], v_imp[1], 0.0, nan),
                    (th_hs - w_hs * d, w_hs, 0.0, nan)))
        sag.append((t_hs, (p_hs[0], v_hs[0], a_hs[0], nan), (p_hs[1], v_hs[1], a_hs[1], nan),
                    (th_hs, w_hs, 0.0, nan)))
        t_r = t_m - t_hs
        for t in (t_hs + t_r / 3, t_hs + 2 * t_r / 3, t_m):  # heel rocker
            th = _profile(th_hs, w_hs, 0, 0, 0, 0, t_r, t - t_hs)
            p, v, a, j = _pivot(G_hs, c_hs, *th)
            sag.append((t, (p[0], v[0], a[0], j[0]), (p[1], v[1], a[1], j[1]), th))
        # exact end pose (rounding in the pivot formula must not leak into the next stance)
        sag[-1] = (t_m, (L, 0.0, 0.0, 0.0), (dz, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0))
        yaw0, yaw1 = self.yaw, self.yaw + turn_rad
        phi_amp = math.radians(gait.roll_amplitude_deg)
        cx, sx = math.cos(chi), math.sin(chi)
        for t, u, z, th in sag:
            k = np.zeros((6, 4))
            k[X] = [self.pos[0] + u[0] * cx, u[1] * cx, u[2] * cx, u[3] * cx]
            k[Y] = [self.pos[1] + u[0] * sx, u[1] * sx, u[2] * sx, u[3] * sx]
            k[Z] = [self.pos[2] + z[0], z[1], z[2], z[3]]
            k[PITCH] = [-th[0], -th[1], -th[2], -th[3]]  # ZYX pitch beta = -theta (nose-up theta)
            k[YAW] = _min_jerk(t, t_to, t_hs, yaw0, yaw1)
            k[ROLL] = (phi_amp, 0.0, 0.0, 0.0) if t == t_mid else (0.0, 0.0, 0.0, 0.0)
            self._append(t0 + t, k)
        self.pos = self.pos + np.array([L * cx, L * sx, dz])
        self.yaw = yaw1
        self._k[-1] = self._rest()
        self.t = t0 + t_m
        self.steps.append(dict(t_start_s=t0, t_toe_off_s=t0 + t_to, t_heel_strike_s=t0 + t_hs, t_end_s=self.t,
                               length_m=L, dz_m=dz, heading_rad=yaw1, turn_rad=turn_rad, chord_heading_rad=chi,
                               gait=self.gaits.setdefault(gait, len(self.gaits)),
                               kind=GAIT_CODES.get(gait.name, -1)))
        return self

    def _toe_move(self, duration_s: float, pos_end: np.ndarray, pitch_end: float, turn_rad: float, gait: Gait,
                  lift_m: float, pitch_bump: float, roll_bump: float, kind: str, n_knots: int = 8) -> None:
        """Move from the current rest pose to the next one about the ball of the foot (module doc, crawling).

        The foot origin ends at ``pos_end`` with pitch ``pitch_end`` and yaw + ``turn_rad``; in between the ball
        follows the ramp S from its start to its end point plus a lift ``lift_m`` H, the pitch the ramp plus
        ``pitch_bump`` H, the yaw the ramp, the roll ``roll_bump`` H. ``n_knots`` knots sample the exact curves.
        Records one row of the step table (``kind``: a GAIT_CODES name).
        """
        t0, T = self.t, float(duration_s)
        yaw0, pitch0, pos0 = self.yaw, self.pitch, self.pos.copy()
        pos_end = np.asarray(pos_end, float)
        ball0 = pos0 + gait.toe_m * _toe_axis(yaw0, pitch0)
        ball1 = pos_end + gait.toe_m * _toe_axis(yaw0 + turn_rad, pitch_end)
        const = np.eye(4)[0]
        for i in range(1, n_knots + 1):
            tau = i / n_knots
            ramp, bump = _jet(_RAMP, tau, T), _jet(_BUMP, tau, T)
            yaw = yaw0 * const + turn_rad * ramp
            pitch = pitch0 * const + (pitch_end - pitch0) * ramp + pitch_bump * bump
            (s_y, c_y), (s_p, c_p) = _jet_sin_cos(yaw), _jet_sin_cos(pitch)
            axis = (_jet_mul(c_y, c_p), _jet_mul(s_y, c_p), -s_p)
            k = np.zeros((6, 4))
            for ch in (X, Y, Z):
                k[ch] = ball0[ch] * const + (ball1[ch] - ball0[ch]) * ramp - gait.toe_m * axis[ch]
            k[Z] += lift_m * bump
            k[YAW], k[PITCH], k[ROLL] = yaw, pitch, roll_bump * bump
            self._append(t0 + tau * T, k)
        self.yaw, self.pitch, self.pos = yaw0 + turn_rad, pitch_end, pos_end
        self._k[-1] = self._rest()  # the exact end pose: no rounding leaks into the next stance
        self.t = t0 + T
        d = pos_end - pos0
        self.steps.append(dict(t_start_s=t0, t_toe_off_s=t0, t_heel_strike_s=self.t, t_end_s=self.t,
                               length_m=float(np.hypot(d[0], d[1])), dz_m=float(d[2]), heading_rad=self.yaw,
                               turn_rad=turn_rad, chord_heading_rad=math.atan2(d[1], d[0]),
                               gait=self.gaits.setdefault(gait, len(self.gaits)), kind=GAIT_CODES[kind]))

    def _crawl_stride(self, length_m: float, dz_m: float, turn_rad: float, gait: Gait, chi: float) -> "PathBuilder":
        """One crawl stride: rest on the toe, then drag the foot ``length_m`` along ``chi`` (module doc)."""
        pitch = math.radians(gait.rest_pitch_deg)
        if abs(self.pitch - pitch) > 1e-12:
            raise ValueError(f"a {gait.name} stride needs the foot on its toe at {gait.rest_pitch_deg:g} deg: "
                             "kneel() first")
        if dz_m:
            raise ValueError("crawling is on the level: dz must be 0")
        T = gait.period_s
        self.stand(gait.still_fraction * T)
        end = self.pos + np.array([length_m * math.cos(chi), length_m * math.sin(chi), 0.0])
        self._toe_move((1 - gait.still_fraction) * T, end, pitch, turn_rad, gait, gait.clearance_m,
                       math.radians(gait.swing_pitch_deg), math.radians(gait.roll_amplitude_deg), gait.name)
        return self

    def kneel(self, gait: Gait = CRAWL, duration_s: float = 1.2) -> "PathBuilder":
        """Go down on hands and knees: the flat foot rotates toe-down about the fixed ball to the crawl's rest
        pitch (the heel rises, the toe stays on the floor)."""
        if self.pitch or not gait.crawl:
            raise ValueError("kneel() needs a flat foot and a crawling gait (rest_pitch_deg > 0)")
        pitch = math.radians(gait.rest_pitch_deg)
        ball = self.pos + gait.toe_m * _toe_axis(self.yaw, 0.0)
        self._toe_move(duration_s, ball - gait.toe_m * _toe_axis(self.yaw, pitch), pitch, 0.0, gait, 0.0, 0.0, 0.0,
                       "kneel")
        return self

    def stand_up(self, gait: Gait = CRAWL, step_m: float = 0.40, lift_m: float = 0.08,
                 duration_s: float = 1.0) -> "PathBuilder":
        """Get up from crawling: the foot leaves its toe and is set down flat with its ball ``step_m`` further
        ahead (lifting ``lift_m`` on the way), under the body, before the person rises."""
        if not self.pitch:
            raise ValueError("stand_up() needs the foot on its toe (crawling)")
        ball = self.pos + gait.toe_m * _toe_axis(self.yaw, self.pitch)  # on the floor
        ball_end = ball + step_m * _toe_axis(self.yaw, 0.0)
        self._toe_move(duration_s, ball_end - gait.toe_m * _toe_axis(self.yaw, 0.0), 0.0, 0.0, gait, lift_m,
                       0.0, 0.0, "stand_up")
        return self

    def walk_to(self, x: float, y: float, gait: Gait = WALK, max_turn_deg: float = 45.0) -> "PathBuilder":
        """Walk in a straight leg to (x, y): turn towards it during the first strides, equal strides."""
        dxy = np.array([x, y]) - self.pos[:2]
        dist = float(np.hypot(*dxy))
        if dist < 1e-9:
            return self
        chi = math.atan2(dxy[1], dxy[0])
        dyaw = (chi - self.yaw + math.pi) % (2 * math.pi) - math.pi
        n = max(1, math.ceil(dist / gait.stride_length_m - 1e-9))
        n_turn = min(n, max(1, math.ceil(abs(math.degrees(dyaw)) / max_turn_deg - 1e-9))) if dyaw else 0
        for i in range(n):
            self.stride(dist / n, 0.0, dyaw / n_turn if i < n_turn else 0.0, gait, chord_heading_rad=chi)
        return self

    def walk(self, distance_m: float, gait: Gait = WALK) -> "PathBuilder":
        """Walk straight ahead (current heading)."""
        return self.walk_to(self.pos[0] + distance_m * math.cos(self.yaw),
                            self.pos[1] + distance_m * math.sin(self.yaw), gait)

    def turn_in_place(self, angle_rad: float, gait: Gait = TURN, max_turn_deg: float = 60.0) -> "PathBuilder":
        n = max(1, math.ceil(abs(math.degrees(angle_rad)) / max_turn_deg))
        for _ in range(n):
            self.stride(gait.stride_length_m, 0.0, angle_rad / n, gait)
        return self

    def stairs(self, n_risers: int, riser_m: float = 0.17, tread_m: float = 0.28, up: bool = True,
               gait: Gait | None = None, steps_per_stride: int = 2) -> "PathBuilder":
        """Climb (or descend) a straight flight: each stride covers ``steps_per_stride`` steps."""
        if n_risers < 1 or riser_m <= 0 or tread_m <= 0:
            raise ValueError("stairs need n_risers >= 1, riser_m > 0, tread_m > 0")
        gait = gait or (STAIRS_UP if up else STAIRS_DOWN)
        left = int(n_risers)
        while left > 0:
            k = min(steps_per_stride, left)
            self.stride(k * tread_m, (1 if up else -1) * k * riser_m, 0.0, gait)
            left -= k
        return self

    # -- result ------------------------------------------------------------------------------
    def build(self) -> Trajectory:
        t = np.array(self._t)
        knots = np.array(self._k)
        # open jerks: central difference of the neighbouring knots' accelerations (keeps the curve C3)
        k_idx, c_idx = np.nonzero(np.isnan(knots[:, :, 3]))
        lo, hi = np.maximum(k_idx - 1, 0), np.minimum(k_idx + 1, len(t) - 1)
        knots[k_idx, c_idx, 3] = (knots[hi, c_idx, 2] - knots[lo, c_idx, 2]) / (t[hi] - t[lo])
        still = np.all(knots[1:] == knots[:-1], axis=(1, 2)) & np.all(knots[1:, :, 1:] == 0, axis=(1, 2))
        return Trajectory(t, knots, still)

    def step_table(self) -> dict[str, np.ndarray]:
        keys = ("t_start_s", "t_toe_off_s", "t_heel_strike_s", "t_end_s", "length_m", "dz_m", "heading_rad",
                "turn_rad", "chord_heading_rad", "gait", "kind")
        return {k: np.array([s[k] for s in self.steps], dtype=np.int16 if k in ("gait", "kind") else float)
                for k in keys}

    def gait_list(self) -> list[dict]:
        """Parameters of every gait used, in the order of the step table's ``gait`` index."""
        return [asdict(g) for g in sorted(self.gaits, key=self.gaits.get)]


def gait_dict(g: Gait) -> dict:
    return asdict(g)


__all__ = ["Gait", "GAITS", "PathBuilder", "WALK", "SHUFFLE", "RUN", "STAIRS_UP", "STAIRS_DOWN", "TURN", "CRAWL",
           "FAST", "CHANNELS"]
