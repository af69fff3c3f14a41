"""Rotations: matrices, axis–angle, Park's metric, Euler angles, geodesics (Sec. III-A).

Conventions
-----------
A rotation is a ``(..., 3, 3)`` float array acting on column vectors, ``R @ u``. ``rot(n, θ)`` turns
right-handedly by ``θ`` about the unit axis ``n``. Park's metric is ``D(R1, R2) = θ(R1ᵀ R2)``, the angle of
the relative rotation, in ``[0, π]``. ZXZ Euler angles ``(α, β, γ)`` mean ``R = R3(α) R1(β) R3(γ)`` and ZYZ
ones ``R = R3(α) R2(β) R3(γ)`` (products of rotations about the fixed basis axes, read right to left: the
intrinsic "ZXZ"/"ZYZ" of SciPy). SciPy's :class:`~scipy.spatial.transform.Rotation` does the conversions.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.spatial.transform import Rotation

from .errors import ComputationError, bad_value


_NEXT, _PREV = np.array([1, 2, 0]), np.array([2, 0, 1])  # (a × b)_i = a_{i+1} b_{i+2} − a_{i+2} b_{i+1}
SMALL_BATCH = 64  # matrices: below this one batched matmul checks RᵀR fastest (benchmarks/bench_contracts.py)
ORTHOGONALITY_TOL = 1e-6  # |RᵀR − I| accepted as a rotation (rounding of products of many rotations)


def as_rotations(R, name: str = "R") -> np.ndarray:
    """The one input contract for rotations: ``R`` as a float array ``(..., 3, 3)`` of proper rotations
    (finite, ``|RᵀR − I| ≤ 1e-6`` entrywise, determinant +1), any leading batch shape; otherwise the project's
    one-line :class:`~spherestep.errors.InputError` naming ``name``."""
    try:
        arr = R if isinstance(R, np.ndarray) and R.dtype == float else np.asarray(R, dtype=float)
    except (TypeError, ValueError):
        raise bad_value(name, "rotation matrices of shape (..., 3, 3)", R) from None
    if arr.ndim < 2 or arr.shape[-2:] != (3, 3):
        raise bad_value(name, "rotation matrices of shape (..., 3, 3)", f"shape {arr.shape}")
    if arr.size == 0:
        return arr
    if arr.size == 9:  # one matrix: plain floats, a few µs (NumPy's per-call overhead would dominate)
        _single_rotation(arr.ravel().tolist(), name)
        return arr
    # proper: det > 0 (NaN fails both tests)
    if arr.size <= 9 * SMALL_BATCH:  # few matrices: fewest NumPy calls (one batched RᵀR, det = (c0 × c1) · c2)
        worst = np.abs(np.matmul(arr.swapaxes(-1, -2), arr) - np.eye(3)).max()
        c0, c1 = arr[..., _NEXT, 0], arr[..., _PREV, 1]
        det = ((c0 * c1 - arr[..., _PREV, 0] * arr[..., _NEXT, 1]) * arr[..., 2]).sum(-1)
    else:  # RᵀR − I from the columns' dot products: 6× faster than a batched 3 × 3 matmul at 10⁴ matrices
        a, b, c = arr[..., 0], arr[..., 1], arr[..., 2]
        dot = functools.partial(np.einsum, "...k,...k->...")
        worst = max(np.max(np.abs(dot(a, a) - 1)), np.max(np.abs(dot(b, b) - 1)), np.max(np.abs(dot(c, c) - 1)),
                    np.max(np.abs(dot(a, b))), np.max(np.abs(dot(a, c))), np.max(np.abs(dot(b, c))))
        det = (arr[..., 0, 0] * (arr[..., 1, 1] * arr[..., 2, 2] - arr[..., 1, 2] * arr[..., 2, 1])
               + arr[..., 0, 1] * (arr[..., 1, 2] * arr[..., 2, 0] - arr[..., 1, 0] * arr[..., 2, 2])
               + arr[..., 0, 2] * (arr[..., 1, 0] * arr[..., 2, 1] - arr[..., 1, 1] * arr[..., 2, 0]))
    if not (worst <= ORTHOGONALITY_TOL and np.min(det) > 0):
        if not np.all(np.isfinite(arr)):
            raise bad_value(name, "finite rotation matrices", "NaN or infinite entries")
        raise bad_value(name, "proper rotation matrices (RᵀR = I within 1e-6, determinant +1)",
                        "a matrix that is not a rotation")
    return arr


def _single_rotation(m: list, name: str) -> None:
    """:func:`as_rotations`' test for one matrix given as its 9 entries, row-major."""
    if not all(map(math.isfinite, m)):
        raise bad_value(name, "finite rotation matrices", "NaN or infinite entries")
    a, b, c, d, e, f, g, h, i = m
    worst = max(abs(a * a + d * d + g * g - 1), abs(b * b + e * e + h * h - 1), abs(c * c + f * f + i * i - 1),
                abs(a * b + d * e + g * h), abs(a * c + d * f + g * i), abs(b * c + e * f + h * i))
    if not (worst <= ORTHOGONALITY_TOL and a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) > 0):
        raise bad_value(name, "proper rotation matrices (RᵀR = I within 1e-6, determinant +1)",
                        "a matrix that is not a rotation")


def _as_scipy(R) -> Rotation:
    R = as_rotations(R)
    return Rotation.from_matrix(R.reshape(-1, 3, 3))


def skew(v) -> np.ndarray:
    """The matrix ``N`` with ``N x = v × x``, shape ``(..., 3, 3)``."""
    v = np.asarray(v, dtype=float)
    zero = np.zeros(v.shape[:-1])
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    return np.stack(
        [np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2
    )


def vect(M) -> np.ndarray:
    """Inverse of :func:`skew` on the antisymmetric part: ``vect(M) = ½ (M32−M23, M13−M31, M21−M12)``."""
    M = np.asarray(M, dtype=float)
    return 0.5 * np.stack(
        [M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]], -1
    )


def rot(axis, angle) -> np.ndarray:
    """Rodrigues' formula ``ROT[n, θ] = I + sin θ N + (1 − cos θ) N²`` with ``n = axis/|axis|``.

    ``axis`` is ``(..., 3)`` (any non-zero length) and ``angle`` broadcasts against ``axis[..., 0]``.

    >>> np.round(rot([0, 0, 1], np.pi / 2) @ [1, 0, 0], 12)
    array([0., 1., 0.])
    """
    axis = np.asarray(axis, dtype=float)
    if axis.shape[-1:] != (3,):
        raise bad_value("axis", "3-vectors of shape (..., 3)", f"shape {axis.shape}")
    norm = np.linalg.norm(axis, axis=-1, keepdims=True)
    if not np.all(np.isfinite(axis)) or np.any(norm == 0):
        raise bad_value("axis", "a finite non-zero 3-vector", axis.tolist())
    angle = np.asarray(angle, dtype=float)
    if not np.all(np.isfinite(angle)):
        raise bad_value("angle", "finite radians", angle.tolist())
    N = skew(axis / norm)
    s = np.sin(angle)[..., None, None]
    c = np.cos(angle)[..., None, None]
    return np.eye(3) + s * N + (1.0 - c) * (N @ N)


def angle(R) -> np.ndarray:
    """The rotation angle ``θ(R)`` in ``[0, π]``.

    Computed as ``atan2(|vect(R − Rᵀ)|/2 … , (tr R − 1)/2)``: unlike ``arccos((tr R − 1)/2)`` it keeps full
    precision near 0 and near π.
    """
    R = as_rotations(R)
    sin_part = np.linalg.norm(vect(R), axis=-1)
    cos_part = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    return np.arctan2(sin_part, cos_part)


def distance(R1, R2, *, trusted: bool = False) -> np.ndarray:
    """Park's metric ``D(R1, R2) = θ(R1ᵀ R2)`` (radians), broadcasting over leading axes. ``trusted=True`` skips
    the input contract, for hot loops whose rotations the package made itself."""
    if not trusted:
        R1 = as_rotations(R1, "R1")
        R2 = as_rotations(R2, "R2")
    M = np.swapaxes(R1, -1, -2) @ R2
    twice_vect = (M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1])
    sin = 0.5 * np.sqrt(twice_vect[0] ** 2 + twice_vect[1] ** 2 + twice_vect[2] ** 2)
    return np.arctan2(sin, 0.5 * (M[..., 0, 0] + M[..., 1, 1] + M[..., 2, 2] - 1.0))


QUATERNION_COLUMNS = ("qw", "qx", "qy", "qz")  # every file the package writes: scalar first, columns named


def quaternion_rows(R) -> np.ndarray:
    """The unit quaternions ``(w, x, y, z)`` (scalar first: the files' order, :data:`QUATERNION_COLUMNS`) of
    rotations ``(..., 3, 3)``, by SciPy (its sign). What every writer of a quaternion column calls; in memory,
    :func:`to_quaternion` keeps SciPy's scalar-last order."""
    R = np.asarray(R, dtype=float)
    return Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat(scalar_first=True).reshape(R.shape[:-2] + (4,))


def to_quaternion(R) -> np.ndarray:
    """Unit quaternions ``(x, y, z, w)`` (SciPy's scalar-last order) of rotations ``(..., 3, 3)``, up to sign, by
    Shepperd's method: of the four forms ``4 q_i q`` (``i = x, y, z, w``) the one with the largest ``q_i²``,
    normalised. Trusted input (no contract check): for the package's KD-trees of states (files use
    :func:`quaternion_rows`, scalar first)."""
    R = np.asarray(R, dtype=float)
    if R.size == 9:  # one matrix: plain floats
        a, b, c, d, e, f, g, h, i = R.ravel().tolist()
        rows = ((1 + a - e - i, b + d, c + g, h - f), (b + d, 1 - a + e - i, f + h, c - g),
                (c + g, f + h, 1 - a - e + i, d - b), (h - f, c - g, d - b, 1 + a + e + i))
        diagonal = [rows[k][k] for k in range(4)]
        q = rows[diagonal.index(max(diagonal))]
        norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        return (np.array(q) / norm).reshape(R.shape[:-2] + (4,))
    a, b, c = R[..., 0, 0], R[..., 0, 1], R[..., 0, 2]
    d, e, f = R[..., 1, 0], R[..., 1, 1], R[..., 1, 2]
    g, h, i = R[..., 2, 0], R[..., 2, 1], R[..., 2, 2]
    forms = np.stack([np.stack([1 + a - e - i, b + d, c + g, h - f], -1),
                      np.stack([b + d, 1 - a + e - i, f + h, c - g], -1),
                      np.stack([c + g, f + h, 1 - a - e + i, d - b], -1),
                      np.stack([h - f, c - g, d - b, 1 + a + e + i], -1)], -2)
    best = np.argmax(np.diagonal(forms, axis1=-2, axis2=-1), axis=-1)
    q = np.take_along_axis(forms, best[..., None, None], axis=-2)[..., 0, :]
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def axis_angle(R) -> tuple[np.ndarray, np.ndarray]:
    """Axis ``n(R)`` (unit, ``(..., 3)``) and angle ``θ(R)`` (``(...)``, in ``[0, π]``) with ``R = rot(n, θ)``.

    Goes through SciPy's quaternion, which stays accurate near θ = 0 and θ = π where ``vect(R − Rᵀ)/(2 sin θ)``
    does not. At θ = 0 the axis is arbitrary and returned as ``(0, 0, 1)``; at θ = π both ``±n`` describe
    ``R``, and the one returned is SciPy's choice.
    """
    R = as_rotations(R)
    rotvec = _as_scipy(R).as_rotvec().reshape(R.shape[:-2] + (3,))
    theta = np.linalg.norm(rotvec, axis=-1)
    safe = np.where(theta > 0, theta, 1.0)[..., None]
    axis = np.where(theta[..., None] > 0, rotvec / safe, np.array([0.0, 0.0, 1.0]))
    return axis, theta


def log(R) -> np.ndarray:
    """Rotation vector ``θ n`` of ``R`` (the matrix logarithm as a 3-vector), ``(..., 3)``."""
    axis, theta = axis_angle(R)
    return axis * theta[..., None]


def log_single(M) -> np.ndarray:
    """:func:`log` of one rotation ``M (3, 3)`` (trusted, not checked): ``θ/sin θ · vect(M)`` with
    ``θ = atan2(|vect M|, (tr M − 1)/2)`` in Python floats (the control loop's hot path, a tenth of :func:`log`'s
    cost; full precision for ``θ < 2.5`` rad), :func:`log` beyond, where that quotient loses digits."""
    (a, b, c), (d, e, f), (g, h, i) = M.tolist()
    x, y, z = 0.5 * (h - f), 0.5 * (c - g), 0.5 * (d - b)
    s = math.sqrt(x * x + y * y + z * z)
    theta = math.atan2(s, 0.5 * (a + e + i - 1.0))
    if theta >= 2.5:
        return log(M)
    k = 1.0 + theta * theta / 6.0 if s < 1e-8 else theta / s
    return np.array([k * x, k * y, k * z])


def exp(rotvec) -> np.ndarray:
    """Rotation matrix of the rotation vector ``v = θ n``, ``(..., 3, 3)``: ``I + a [v]× + b [v]×²`` with
    ``a = sin θ / θ`` and ``b = (1 − cos θ)/θ²`` (Taylor series below θ = 1e-4, full precision everywhere)."""
    rotvec = np.asarray(rotvec, dtype=float)
    if rotvec.shape[-1:] != (3,) or not np.all(np.isfinite(rotvec)):
        raise bad_value("rotvec", "finite rotation vectors of shape (..., 3)", f"shape {rotvec.shape}")
    if rotvec.size == 3:  # one rotation (the integrator's inner loop): scalar arithmetic, no array overhead
        return _exp_one(*rotvec.ravel().tolist()).reshape(rotvec.shape[:-1] + (3, 3))
    t2 = np.sum(rotvec * rotvec, axis=-1)
    t = np.sqrt(t2)
    small = t < 1e-4
    safe = np.where(small, 1.0, t)
    a = np.where(small, 1.0 - t2 / 6.0 + t2 * t2 / 120.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 - t2 / 24.0 + t2 * t2 / 720.0, (1.0 - np.cos(safe)) / (safe * safe))
    K = skew(rotvec)
    return np.eye(3) + a[..., None, None] * K + b[..., None, None] * (K @ K)


def _exp_one(x: float, y: float, z: float) -> np.ndarray:
    """:func:`exp` of one rotation vector with Python floats (same formula and series)."""
    return np.array(exp_entries(x, y, z)).reshape(3, 3)


def exp_entries(x: float, y: float, z: float) -> tuple[float, ...]:
    """The 9 entries (row-major) of :func:`exp` of ``(x, y, z)`` in scalar arithmetic: the one formula for Python
    floats and for the compiled integrator (:mod:`spherestep._fast.terms` compiles this function)."""
    t2 = x * x + y * y + z * z
    if t2 < 1e-8:
        a, b = 1.0 - t2 / 6.0 + t2 * t2 / 120.0, 0.5 - t2 / 24.0 + t2 * t2 / 720.0
    else:
        t = math.sqrt(t2)
        a, b = math.sin(t) / t, (1.0 - math.cos(t)) / t2
    return (1.0 - b * (y * y + z * z), b * x * y - a * z, b * x * z + a * y,
            b * x * y + a * z, 1.0 - b * (x * x + z * z), b * y * z - a * x,
            b * x * z - a * y, b * y * z + a * x, 1.0 - b * (x * x + y * y))


def from_euler_zxz(angles) -> np.ndarray:
    """``R3(α) R1(β) R3(γ)`` from ``angles = (..., 3)`` holding ``(α, β, γ)``, the convention of eq. (8)."""
    return _from_euler("ZXZ", angles)


def to_euler_zxz(R) -> np.ndarray:
    """``(α, β, γ)`` with ``R = R3(α) R1(β) R3(γ)``, ``β ∈ [0, π]``, ``α, γ ∈ (−π, π]``; shape ``(..., 3)``.

    From the unit quaternion ``q = (w, x, y, z) = (cos(β/2) cos(σ/2), sin(β/2) cos(δ/2), sin(β/2) sin(δ/2),
    cos(β/2) sin(σ/2))`` with ``σ = α + γ = 2 atan2(z, w)``, ``δ = α − γ = 2 atan2(y, x)`` and
    ``β = 2 atan2(|(x, y)|, |(w, z)|)``. Near ``β = 0`` the sum ``σ`` stays exact and ``δ`` matters only
    through ``sin(β/2)``, so ``R`` is reproduced to rounding; SciPy's ``as_euler`` sets ``γ = 0`` below
    ``β ≈ 1e−7`` and so moves ``R`` by up to ``β``. At ``β = 0`` (or π) only ``α ± γ`` is defined; the split
    returned is the one the formulas give.
    """
    R = as_rotations(R)
    x, y, z, w = np.moveaxis(Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat(), -1, 0)
    total = 2.0 * np.arctan2(z, w)
    difference = 2.0 * np.arctan2(y, x)
    beta = 2.0 * np.arctan2(np.hypot(x, y), np.hypot(w, z))
    angles = np.stack([_wrap(0.5 * (total + difference)), beta, _wrap(0.5 * (total - difference))], axis=-1)
    return angles.reshape(R.shape[:-2] + (3,))


def from_euler_zyz(angles) -> np.ndarray:
    """``R3(α) R2(β) R3(γ)`` from ``(..., 3)`` angles, the convention of eq. (9)."""
    return _from_euler("ZYZ", angles)


def to_euler_zyz(R) -> np.ndarray:
    """``(α, β, γ)`` with ``R = R3(α) R2(β) R3(γ)``; shape ``(..., 3)``.

    Uses ``R_ZYZ(α, β, γ) = R_ZXZ(α + π/2, β, γ − π/2)`` (Sec. III-B-2) on :func:`to_euler_zxz`.
    """
    zxz = to_euler_zxz(R)
    return np.stack([_wrap(zxz[..., 0] - np.pi / 2), zxz[..., 1], _wrap(zxz[..., 2] + np.pi / 2)], axis=-1)


def _wrap(angle: np.ndarray) -> np.ndarray:
    """Angles wrapped into ``(−π, π]``."""
    return np.pi - np.mod(np.pi - angle, 2 * np.pi)


def _from_euler(seq: str, angles) -> np.ndarray:
    angles = np.asarray(angles, dtype=float)
    if angles.shape[-1:] != (3,) or not np.all(np.isfinite(angles)):
        raise bad_value("angles", "finite Euler angles of shape (..., 3)", f"shape {angles.shape}")
    flat = Rotation.from_euler(seq, angles.reshape(-1, 3)).as_matrix()
    return flat.reshape(angles.shape[:-1] + (3, 3))


def random(n: int, rng: np.random.Generator | int | None = None) -> np.ndarray:
    """``n`` rotations drawn uniformly (Haar measure) on SO(3), ``(n, 3, 3)``."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise bad_value("n", "a non-negative integer", n)
    rng = np.random.default_rng(rng)
    return Rotation.random(int(n), random_state=rng).as_matrix().reshape(int(n), 3, 3)


def geodesic(R1, R2, t) -> np.ndarray:
    """Point ``R1 exp(t log(R1ᵀ R2))`` on the shortest geodesic from ``R1`` (t = 0) to ``R2`` (t = 1).

    ``t`` may be an array; the result has shape ``t.shape + (3, 3)`` for single ``R1``, ``R2``.
    """
    R1 = as_rotations(R1, "R1")
    R2 = as_rotations(R2, "R2")
    t = np.asarray(t, dtype=float)
    omega = log(np.swapaxes(R1, -1, -2) @ R2)
    return R1 @ exp(omega * t[..., None])


def turned_angle(rotations, axis) -> np.ndarray:
    """Cumulative angle (rad) turned about the fixed-frame ``axis`` along ``rotations (T, 3, 3)``:
    ``ψ_0 = 0``, ``ψ_k = ψ_{k−1} + n · log(R_k R_{k−1}ᵀ)`` (unwrapped, so a full turn gives 2π)."""
    R = as_rotations(rotations, "rotations")
    n = np.asarray(axis, dtype=float)
    n = n / np.linalg.norm(n)
    steps = log(R[1:] @ np.swapaxes(R[:-1], 1, 2)) @ n
    return np.concatenate([[0.0], np.cumsum(steps)])


def path_length(keys) -> float:
    """Length of the piecewise-geodesic path through ``keys`` ``(m, 3, 3)``: the sum of Park distances."""
    keys = as_rotations(keys, "path")
    return float(np.sum(distance(keys[:-1], keys[1:])))


def resample(path, n: int) -> np.ndarray:
    """``n + 1`` rotations on the piecewise-geodesic path through ``path`` ``(m, 3, 3)`` with equal steps.

    The first and last rotations are the path's ends, and consecutive rotations are at one common Park
    distance: ``D(R_{i−1}, R_i) = D(R_i, R_{i+1})`` (Sec. III-A). On a single geodesic this is equal arc
    length. Across a corner the chord is shorter than the arc, so the arc-length positions ``s_1 … s_{n−1}``
    are solved for by Newton's method on ``r_i = D_{i+1} − D_i = 0`` from equal arc lengths. The Jacobian is
    tridiagonal and exact: moving ``R_i`` along the path at unit body rate ``ŵ`` changes
    ``D(R_{i−1}, R_i)`` at rate ``n(R_{i−1}ᵀ R_i) · ŵ`` and ``D(R_i, R_{i+1})`` at rate ``−n(R_iᵀ R_{i+1}) · ŵ``.
    Equal steps need not exist: where the path turns sharply the chord across the corner shrinks and, as
    for a hairpin, only some step counts fit. When damped Newton does not reach 1e-12 rad a
    ComputationError says so (add keys to round the corner, or change ``n``). Consecutive keys must be less
    than π apart (otherwise the geodesic between them is not unique); a full turn is given as several keys.
    """
    from scipy.linalg import solve_banded

    keys = as_rotations(path, "path")
    if keys.ndim != 3 or keys.shape[0] < 2:
        raise bad_value("path", "at least two rotations, shape (m, 3, 3) with m >= 2", f"shape {keys.shape}")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise bad_value("n", "a positive integer number of steps", n)
    n = int(n)
    seg = distance(keys[:-1], keys[1:])
    if np.any(seg > np.pi - 1e-9):
        raise bad_value("path", "consecutive rotations less than π apart (split a long turn into pieces)",
                        f"a segment of {np.degrees(seg.max()):.3f}°")
    omegas = log(np.swapaxes(keys[:-1], -1, -2) @ keys[1:])  # tangent of each segment, |ω| = its length
    moving = seg > 0  # drop repeated keys
    starts, omegas, seg = keys[:-1][moving], omegas[moving], seg[moving]
    total = float(seg.sum())
    if total == 0.0:
        return np.repeat(keys[-1][None], n + 1, axis=0)
    cumulative = np.concatenate([[0.0], np.cumsum(seg)])
    rates = omegas / seg[:, None]  # unit body angular velocity on each segment

    def locate(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        j = np.clip(np.searchsorted(cumulative, s, side="right") - 1, 0, len(seg) - 1)
        return j, np.clip((s - cumulative[j]) / seg[j], 0.0, 1.0)

    def at(s: np.ndarray) -> np.ndarray:
        j, t = locate(s)
        return starts[j] @ exp(omegas[j] * t[:, None])

    def steps(arc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        P = at(arc)
        return axis_angle(np.swapaxes(P[:-1], 1, 2) @ P[1:])  # axes n_i (body frame) and d_i = D(P_{i−1}, P_i)

    arc = np.linspace(0.0, total, n + 1)
    axis, d = steps(arc)
    r = d[1:] - d[:-1]
    for _ in range(100):
        if n == 1 or np.abs(r).max() <= 1e-13:
            break
        w = rates[locate(arc)[0]]
        # r_i = d_{i+1} − d_i depends on s_{i−1}, s_i, s_{i+1}
        lower = np.einsum("ic,ic->i", axis[1:-1], w[1:-2])            # ∂r_i/∂s_{i−1} = n_i·ŵ_{i−1}
        diag = -np.einsum("ic,ic->i", axis[1:] + axis[:-1], w[1:-1])  # −(n_{i+1} + n_i)·ŵ_i
        upper = np.einsum("ic,ic->i", axis[1:-1], w[2:-1])            # ∂r_i/∂s_{i+1} = n_{i+1}·ŵ_{i+1}
        bands = np.zeros((3, n - 1))
        bands[0, 1:], bands[1], bands[2, :-1] = upper, diag, lower
        delta = solve_banded((1, 1), bands, -r)
        scale, norm = 1.0, np.linalg.norm(r)
        while scale > 1e-6:  # damped: keep the positions ordered and the residual falling
            trial = arc.copy()
            trial[1:-1] += scale * delta
            if np.all(np.diff(trial) > 0):
                t_axis, t_d = steps(trial)
                t_r = t_d[1:] - t_d[:-1]
                if np.linalg.norm(t_r) < norm:
                    arc, axis, d, r = trial, t_axis, t_d, t_r
                    break
            scale *= 0.5
        else:
            break
    if n > 1 and np.abs(r).max() > 1e-12:
        raise ComputationError(f"no equal spacing of {n} steps found on this path (steps still differ by "
                               f"{np.abs(r).max():.2g} rad): its corners are too sharp; add keys or change n")
    out = at(arc)
    out[-1] = keys[-1]
    return out
