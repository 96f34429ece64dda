"""Pedestrian dead reckoning (step-and-heading) for waist, lower-back and phone sensors.

Public API:
    run_pdr(t_s, acc_b, gyro_b=None, settings=PdrSettings(), mag_b=None, compass_deg=None) -> PdrResult
    PdrSettings (dataclass, to_dict), PdrResult
    detectors.DETECTORS / make_detector, length.LENGTH_MODELS, heading.*, path.*, foot_ins.steps_from_foot_ins
    (the PDR benchmark's trials and scoring: bootnav.postproc.evaluate.pdr)

Sources: [NKUA2009] (a waist-worn PDR system, NKUA thesis 2009), [Bayindir2014] (an evaluation of three
phone step detectors and four step-length models), [Lazarevskiy2021] (a phone PDR system, NAU Kyiv thesis
2021). Each module says which parameters are literal and which are engineered.
"""

__all__ = ["PdrResult", "PdrSettings", "run_pdr"]


def __getattr__(name: str):
    """The pipeline's names on first use (PEP 562): importing ``bootnav.postproc.pdr.cli`` (every ``bootnav``
    command builds its parser) then imports no numpy."""
    if name in __all__:
        from bootnav.postproc.pdr import pipeline

        return getattr(pipeline, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
