"""The step detectors' registry and base class (the pattern of the stance detectors, ``bootnav.core.registry``).

``@register("name")`` enters a ``StepDetector`` subclass into ``DETECTORS`` under the name of
``bootnav pdr --detector``; the dataclass fields are its parameters (``--detector-param NAME=VALUE``,
``PdrSettings.detector_params``), saved with the results by ``to_dict``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import ClassVar

from bootnav.core.registry import Registry

DETECTORS = Registry("step detector")
register = DETECTORS.register


@dataclass
class StepDetector:
    """Base of the step detectors: ``detect(t_s, acc_b) -> StepEvents`` (acc_b: (N, 3) specific force in the
    sensor frame, m/s², gravity included; t_s: the recording's own clock)."""

    name: ClassVar[str] = ""

    def to_dict(self) -> dict:
        """The parameters, as saved with the results."""
        return asdict(self)

    def detect(self, t_s, acc_b):
        raise NotImplementedError
