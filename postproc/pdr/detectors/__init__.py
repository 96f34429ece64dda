"""Step detectors: one module per method, each a small dataclass with documented parameters and one
``detect(t_s, acc_b) -> StepEvents`` entry (acc_b: (N, 3) specific force in the sensor frame, m/s^2,
gravity included; t_s: the recording's own clock, any rate, duplicates/gaps allowed).

Each registers itself with ``@register("name")`` (``base.py``, the stance detectors' pattern) into
``DETECTORS``, name -> class; a new detector is a new module decorated so and imported here.
"""

from __future__ import annotations

from bootnav.postproc.pdr.detectors.base import DETECTORS, StepDetector, register

# importing the modules fills DETECTORS (in this order: the order --detector lists them)
from bootnav.postproc.pdr.detectors.robust import RobustDetector  # noqa: E402,F401  isort: skip
from bootnav.postproc.pdr.detectors.peak_valley import PeakValleyDetector  # noqa: F401  isort: skip
from bootnav.postproc.pdr.detectors.zero_crossing import ZeroCrossingDetector  # noqa: F401  isort: skip
from bootnav.postproc.pdr.detectors.pan_tompkins import PanTompkinsDetector  # noqa: F401  isort: skip
from bootnav.postproc.pdr.detectors.template import TemplateDetector  # noqa: F401  isort: skip
from bootnav.postproc.pdr.detectors.two_axis import TwoAxisFootDetector  # noqa: F401  isort: skip
from bootnav.postproc.pdr.detectors.footpath import FootPathDetector  # noqa: F401  isort: skip
from bootnav.postproc.pdr.detectors.leppakoski import LeppakoskiDetector  # noqa: F401  isort: skip
from bootnav.postproc.pdr.detectors.li import LiDetector  # noqa: F401  isort: skip
from bootnav.postproc.pdr.detectors.peak_group import PeakGroupDetector  # noqa: F401  isort: skip

__all__ = ["DETECTORS", "StepDetector", "make_detector", "register"]


def make_detector(name: str, **params):
    """Instantiate a detector by registry name with parameter overrides."""
    from bootnav.errors import InputError

    if name not in DETECTORS:
        raise InputError(f"unknown step detector {name!r}; choose one of {sorted(DETECTORS)}")
    return DETECTORS[name](**params)
