"""The step-length models' registry and base class (the pattern of the stance detectors,
``bootnav.core.registry``).

``@register("name")`` enters a ``StepLengthModel`` subclass into ``LENGTH_MODELS`` under the name of
``bootnav pdr --length``; the dataclass fields are its parameters (``--length-param NAME=VALUE``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import ClassVar

from bootnav.core.registry import Registry

LENGTH_MODELS = Registry("step-length model")
register = LENGTH_MODELS.register


@dataclass
class StepLengthModel:
    """Base of the step-length models: ``estimate(features) -> (N,) m`` from ``StepFeatures``."""

    name: ClassVar[str] = ""

    def to_dict(self) -> dict:
        """The parameters, as saved with the results."""
        return asdict(self)

    def estimate(self, feat):
        raise NotImplementedError
