"""Step-length models: one module per model, each a dataclass with ``estimate(features) -> (N,) m``.

``StepFeatures`` (features.py) gives every model what it needs per step: step frequency, vertical
acceleration range, magnitude standard deviation/variance, in SI units. Each model registers itself with
``@register("name")`` (``base.py``, the stance detectors' pattern) into ``LENGTH_MODELS``, name -> class.
"""

from __future__ import annotations

from bootnav.postproc.pdr.length.base import LENGTH_MODELS, StepLengthModel, register
from bootnav.postproc.pdr.length.features import StepFeatures, step_features

# importing the modules fills LENGTH_MODELS (in this order: the order --length lists them)
from bootnav.postproc.pdr.length.weinberg import WeinbergLength  # noqa: F401  isort: skip
from bootnav.postproc.pdr.length.ladetto import LadettoLength  # noqa: F401  isort: skip
from bootnav.postproc.pdr.length.constant import ConstantLength, FootPathLength  # noqa: F401  isort: skip
from bootnav.postproc.pdr.length.frequency import FrequencyLength  # noqa: F401  isort: skip
from bootnav.postproc.pdr.length.renaudin import RenaudinLength  # noqa: F401  isort: skip
from bootnav.postproc.pdr.length.frequency_variance import FrequencyVarianceLength  # noqa: F401  isort: skip

__all__ = ["LENGTH_MODELS", "StepFeatures", "StepLengthModel", "register", "step_features"]
