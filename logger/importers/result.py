"""``ImportResult``: what every reader of ``bootnav.logger.importers`` returns (parsed, checked, in memory)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bootnav.logger.recording import Channel


@dataclass
class ImportResult:
    """A parsed, checked import, before (or after) writing it as a recording."""

    source: Path
    profile: str
    t_s: np.ndarray
    acc: np.ndarray  # as delivered: int16 counts, or floats in the file's unit
    gyro: np.ndarray  # as delivered, NaN when the file has no gyro
    acc_channel: Channel
    gyro_channel: Channel
    saturated: np.ndarray
    events: list[dict]
    meta: dict[str, Any]
    aux: dict[str, np.ndarray] = field(default_factory=dict)
    aux_units: dict[str, str] = field(default_factory=dict)
    optional: dict[str, Any] = field(default_factory=dict)  # temp, temp_channel, t_device, seq (SD logs)
    messages: list[str] = field(default_factory=list)  # what was detected / skipped, for the user

    @property
    def n(self) -> int:
        return int(self.t_s.shape[0])

    @property
    def acc_mps2(self) -> np.ndarray:
        return self.acc.astype(np.float64) * self.acc_channel.scale_to_si

    @property
    def gyro_radps(self) -> np.ndarray:
        return self.gyro.astype(np.float64) * self.gyro_channel.scale_to_si

    def count(self, kind: str) -> int:
        return sum(1 for e in self.events if e["kind"] == kind)
