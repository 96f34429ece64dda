"""Pedestrian dead reckoning (step-and-heading) for waist, lower-back and phone sensors.

Public API:
    run_pdr(t_s, acc_b, gyro_b=None, settings=PdrSettings(), mag_b=None) -> PdrResult
    PdrSettings (dataclass, to_dict), PdrResult
    detectors.DETECTORS / make_detector, length.LENGTH_MODELS, heading.*, path.*, foot_ins.steps_from_foot_ins
    evaluate.event_metrics / step_length_metrics / evaluate_trial

Sources: ../shared/reference/seed-000.md (NKUA 2009 waist system), seed-002.md (Turkish evaluation),
seed-003.md (NAU Kyiv 2021 phone system). Each module says which parameters are literal and which are
engineered.
"""

from bootnav.postproc.pdr.pipeline import PdrResult, PdrSettings, run_pdr

__all__ = ["PdrResult", "PdrSettings", "run_pdr"]
