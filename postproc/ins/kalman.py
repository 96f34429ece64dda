"""Kalman measurement-update kernels of the fast engine, for an H that selects states of the error state.

With H = [0 … I_m … 0] (columns ``first``..``first+m−1``) no H matrix is formed: P Hᵀ is a column block of P,
H P Hᵀ a diagonal block. Gain K = P Hᵀ (H P Hᵀ + R)⁻¹ (closed-form 3×3 inverse for m = 3, a division for
m = 1), Joseph form P ← (I − K H) P (I − K H)ᵀ + K R Kᵀ [Groves2013] computed by blocks, symmetric by
construction. Inlined by numba (``inline="always"``) so each call site is specialised for its constant H block.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, inline="always")
def joseph3(P, K, off, r, n, A):
    """P ← (I − K H) P (I − K H)ᵀ + r K Kᵀ for H selecting states off..off+2 (block form).

    The rows' factors are loaded into locals and the lower triangle is mirrored after the upper one is
    complete, so that the inner loops run over contiguous rows (vectorised); every entry is the same
    expression in the same order as the textbook loop, so the result is bit for bit the same."""
    for i in range(n):
        k0, k1, k2 = K[i, 0], K[i, 1], K[i, 2]
        for c in range(n):
            A[i, c] = P[i, c] - (k0 * P[off, c] + k1 * P[off + 1, c] + k2 * P[off + 2, c])
    for i in range(n):  # the result is symmetric: compute the upper triangle, mirror it
        a0, a1, a2 = A[i, off], A[i, off + 1], A[i, off + 2]
        k0, k1, k2 = K[i, 0], K[i, 1], K[i, 2]
        for c in range(i, n):
            P[i, c] = ((A[i, c] - (a0 * K[c, 0] + a1 * K[c, 1] + a2 * K[c, 2]))
                       + r * (k0 * K[c, 0] + k1 * K[c, 1] + k2 * K[c, 2]))
    for i in range(n):
        for c in range(i):
            P[i, c] = P[c, i]


@njit(cache=True, inline="always")
def innovation_cofactors(P, off, r):
    """The cofactors m_ij (row-major) and determinant of S = H P Hᵀ + r I, H selecting states off..off+2, so that
    S⁻¹ = [m_ij] / det: a general 3×3 inverse (S is symmetric up to rounding; all entries are used so that it
    equals numpy's inverse)."""
    a, b, c = P[off, off] + r, P[off, off + 1], P[off, off + 2]
    d, e = P[off + 1, off + 1] + r, P[off + 1, off + 2]
    f = P[off + 2, off + 2] + r
    b2, c2, e2 = P[off + 1, off], P[off + 2, off], P[off + 2, off + 1]
    m00, m01, m02 = d * f - e * e2, c * e2 - b * f, b * e - c * d
    m10, m11, m12 = e * c2 - b2 * f, a * f - c * c2, c * b2 - a * e
    m20, m21, m22 = b2 * e2 - d * c2, b * c2 - a * e2, a * d - b * b2
    return m00, m01, m02, m10, m11, m12, m20, m21, m22, a * m00 + b * m10 + c * m20


@njit(cache=True, inline="always")
def kalman_gain3(P, off, r, n, K):
    """K = P Hᵀ (H P Hᵀ + r I)⁻¹ for H selecting states off..off+2 (closed-form 3×3 inverse)."""
    m00, m01, m02, m10, m11, m12, m20, m21, m22, det = innovation_cofactors(P, off, r)
    for i in range(n):
        p0, p1, p2 = P[i, off], P[i, off + 1], P[i, off + 2]
        K[i, 0] = (p0 * m00 + p1 * m10 + p2 * m20) / det
        K[i, 1] = (p0 * m01 + p1 * m11 + p2 * m21) / det
        K[i, 2] = (p0 * m02 + p1 * m12 + p2 * m22) / det


@njit(cache=True, inline="always")
def scalar_update(P, idx, r, n, K, A):
    """Gain (into K[:, 0]) and Joseph update for a scalar measurement of state idx with variance r (loops
    arranged as ``joseph3``'s, same result bit for bit)."""
    s = P[idx, idx] + r
    for i in range(n):
        K[i, 0] = P[i, idx] / s
    for i in range(n):
        k0 = K[i, 0]
        for c in range(n):
            A[i, c] = P[i, c] - k0 * P[idx, c]
    for i in range(n):
        ai, k0 = A[i, idx], K[i, 0]
        for c in range(i, n):
            P[i, c] = A[i, c] - ai * K[c, 0] + r * k0 * K[c, 0]
    for i in range(n):
        for c in range(i):
            P[i, c] = P[c, i]


@njit(cache=True, inline="always")
def sequential_update(P, dx, z, m, first, r, n, K, A):
    """Kalman update of (dx, P) with z = H δx + ν, H selecting states first..first+m−1, R = r I (m = 1 or 3).

    Sequential: the innovation is z − H dx, dx holding the corrections of the earlier models of this sample.
    """
    if m == 3:
        kalman_gain3(P, first, r, n, K)
        z0, z1, z2 = z[0] - dx[first], z[1] - dx[first + 1], z[2] - dx[first + 2]
        for i in range(n):
            dx[i] += K[i, 0] * z0 + K[i, 1] * z1 + K[i, 2] * z2
        joseph3(P, K, first, r, n, A)
    elif m == 1:
        scalar_update(P, first, r, n, K, A)
        zi = z[0] - dx[first]
        for i in range(n):
            dx[i] += K[i, 0] * zi
    else:
        raise ValueError("fast engine: a measurement model must have 1 or 3 rows")


@njit(cache=True, inline="always")
def innovation_weight(P, dx, z, m, first, r, out):
    """out[:m] ← S⁻¹ ν, the innovation ν = z − H dx weighted by the inverse of its covariance S = H P Hᵀ + r I
    (H selecting states first..first+m−1; P and dx before the update). With K = P Hᵀ S⁻¹ it is what the
    smoother needs of the update besides K: P⁻⁻¹ K ν = Hᵀ S⁻¹ ν (``smoother.rts_backward``)."""
    if m == 3:
        off = first
        m00, m01, m02, m10, m11, m12, m20, m21, m22, det = innovation_cofactors(P, off, r)
        v0, v1, v2 = z[0] - dx[off], z[1] - dx[off + 1], z[2] - dx[off + 2]
        out[0] = (m00 * v0 + m01 * v1 + m02 * v2) / det
        out[1] = (m10 * v0 + m11 * v1 + m12 * v2) / det
        out[2] = (m20 * v0 + m21 * v1 + m22 * v2) / det
    else:
        out[0] = (z[0] - dx[first]) / (P[first, first] + r)
