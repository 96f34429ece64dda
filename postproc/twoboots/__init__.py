"""Two boots, one walker: fuse both feet's ZUPT navigators with the maximum-separation constraint [Skog2012].

* ``settings.TwoBootSettings``: the bound γ (anthropometry), the constraint instants, clock and frame rules;
* ``constraint``: the covariance-weighted projection onto ‖p_L − p_R‖ ≤ γ and its pseudo-measurement;
* ``align``: the session clock check (gait symmetry) and the frame alignment (yaw) of the two feet;
* ``fusion``: both ``StreamNavigator``s in lockstep with the constraint;
* ``gaitmetrics``: the walker's path, per-foot strides and step width;
* ``run.process_two_boots``: the whole pipeline (each foot alone, clock, frame, fusion, gait, summary);
* ``outputs``: the files of ``bootnav process LEFT RIGHT --two-boots``.
"""

__all__ = ["TwoBootResult", "TwoBootSettings", "process_two_boots"]


def __getattr__(name: str):
    """Resolve the public names on first use (PEP 562): ``process --help`` imports this package's ``cli`` and
    must stay free of numpy and h5py."""
    if name == "TwoBootSettings":
        from .settings import TwoBootSettings

        return TwoBootSettings
    if name in ("TwoBootResult", "process_two_boots"):
        from . import run

        return getattr(run, name)
    raise AttributeError(f"module 'bootnav.postproc.twoboots' has no attribute {name!r}")
