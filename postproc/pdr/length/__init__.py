"""Step-length models: one module per model, each a dataclass with ``estimate(features) -> (N,) m``.

``StepFeatures`` (features.py) gives every model what it needs per step: step frequency, vertical
acceleration range, magnitude standard deviation/variance, in SI units.
"""

from __future__ import annotations

from bootnav.postproc.pdr.length.constant import ConstantLength, FootPathLength
from bootnav.postproc.pdr.length.features import StepFeatures, step_features
from bootnav.postproc.pdr.length.frequency import FrequencyLength
from bootnav.postproc.pdr.length.frequency_variance import FrequencyVarianceLength
from bootnav.postproc.pdr.length.ladetto import LadettoLength
from bootnav.postproc.pdr.length.renaudin import RenaudinLength
from bootnav.postproc.pdr.length.weinberg import WeinbergLength

LENGTH_MODELS = {
    "weinberg": WeinbergLength,
    "ladetto": LadettoLength,
    "footpath": FootPathLength,
    "constant": ConstantLength,
    "frequency": FrequencyLength,
    "renaudin": RenaudinLength,
    "frequency_variance": FrequencyVarianceLength,
}

__all__ = ["LENGTH_MODELS", "StepFeatures", "step_features"]
