"""Constant step lengths.

* FootPath (seed-002 §2.1, eq. 2):  L = 0.415 h,  h = 1.83 m [literal Table 2] -> 0.75945 m.
* Constant (seed-000 §5.1): L = 0.5 m [literal example].
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np


@dataclass
class FootPathLength:
    height_m: float = 1.83
    k: float = 0.415

    name = "footpath"

    def to_dict(self) -> dict:
        return asdict(self)

    def estimate(self, feat) -> np.ndarray:
        return np.full(len(feat), self.k * self.height_m)


@dataclass
class ConstantLength:
    length_m: float = 0.5

    name = "constant"

    def to_dict(self) -> dict:
        return asdict(self)

    def estimate(self, feat) -> np.ndarray:
        return np.full(len(feat), self.length_m)
