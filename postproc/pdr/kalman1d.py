"""Two-measurement fusion ([NKUA2009, §3.2]; theory only in the thesis, Maybeck ch. 1):

    K = s1^2 / (s1^2 + s2^2),   x^ = z1 + K (z2 - z1),   1/s^2 = 1/s1^2 + 1/s2^2
"""

from __future__ import annotations


def fuse_two(z1: float, var1: float, z2: float, var2: float) -> tuple[float, float, float]:
    """Returns (estimate, variance, gain K)."""
    k = var1 / (var1 + var2)
    return z1 + k * (z2 - z1), 1.0 / (1.0 / var1 + 1.0 / var2), k
