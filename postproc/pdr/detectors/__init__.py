"""Step detectors: one module per method, each a small dataclass with documented parameters and one
``detect(t_s, acc_b) -> StepEvents`` entry (acc_b: (N, 3) specific force in the sensor frame, m/s^2,
gravity included; t_s: the recording's own clock, any rate, duplicates/gaps allowed).

Registry ``DETECTORS`` maps the CLI names to the classes.
"""

from __future__ import annotations

from bootnav.postproc.pdr.detectors.footpath import FootPathDetector
from bootnav.postproc.pdr.detectors.leppakoski import LeppakoskiDetector
from bootnav.postproc.pdr.detectors.li import LiDetector
from bootnav.postproc.pdr.detectors.pan_tompkins import PanTompkinsDetector
from bootnav.postproc.pdr.detectors.peak_group import PeakGroupDetector
from bootnav.postproc.pdr.detectors.peak_valley import PeakValleyDetector
from bootnav.postproc.pdr.detectors.robust import RobustDetector
from bootnav.postproc.pdr.detectors.template import TemplateDetector
from bootnav.postproc.pdr.detectors.two_axis import TwoAxisFootDetector
from bootnav.postproc.pdr.detectors.zero_crossing import ZeroCrossingDetector

DETECTORS = {
    "robust": RobustDetector,
    "peak_valley": PeakValleyDetector,
    "zero_crossing": ZeroCrossingDetector,
    "pan_tompkins": PanTompkinsDetector,
    "template": TemplateDetector,
    "two_axis": TwoAxisFootDetector,
    "footpath": FootPathDetector,
    "leppakoski": LeppakoskiDetector,
    "li": LiDetector,
    "peak_group": PeakGroupDetector,
}


def make_detector(name: str, **params):
    """Instantiate a detector by registry name with parameter overrides."""
    from bootnav.errors import InputError

    if name not in DETECTORS:
        raise InputError(f"unknown step detector {name!r}; choose one of {sorted(DETECTORS)}")
    return DETECTORS[name](**params)
