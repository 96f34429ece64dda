"""ZUPT-aided strapdown navigation: mechanization, error-state Kalman filter, Riccati mode, RTS smoothing.

Public API (the postproc API contract):
    run_filter(t_s, acc_b, gyro_b, stance, init, gravity, settings, progress=None) -> NavSolution
    FilterSettings, NavSolution, steady_state_gain(...) -> RiccatiReport
"""

from bootnav.postproc.ins.filter import NavSolution, run_filter
from bootnav.postproc.ins.riccati import RiccatiReport, steady_state_gain
from bootnav.postproc.ins.settings import FilterSettings

__all__ = ["FilterSettings", "NavSolution", "RiccatiReport", "run_filter", "steady_state_gain"]
