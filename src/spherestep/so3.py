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

import warnings

import numpy as np
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from .errors import bad_value


def _as_rotations(R, name: str = "R") -> np.ndarray:
    R = np.asarray(R, dtype=float)
    if R.shape[-2:] != (3, 3):
        raise bad_value(name, "an array of rotation matrices of shape (..., 3, 3)", f"shape {R.shape}")
    if not np.all(np.isfinite(R)):
        raise bad_value(name, "finite rotation matrices", "NaN or infinite entries")
    return R


def _as_scipy(R) -> Rotation:
    R = _as_rotations(R)
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
    R = _as_rotations(R)
    sin_part = np.linalg.norm(vect(R), axis=-1)
    cos_part = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    return np.arctan2(sin_part, cos_part)


def distance(R1, R2) -> np.ndarray:
    """Park's metric ``D(R1, R2) = θ(R1ᵀ R2)`` (radians), broadcasting over leading axes."""
    R1 = _as_rotations(R1, "R1")
    R2 = _as_rotations(R2, "R2")
    return angle(np.swapaxes(R1, -1, -2) @ R2)


def axis_angle(R) -> tuple[np.ndarray, np.ndarray]:
    """Axis ``n(R)`` (unit, ``(..., 3)``) and angle ``θ(R)`` (``(...)``, in ``[0, π]``) with ``R = rot(n, θ)``.

    Goes through SciPy's quaternion, which stays accurate near θ = 0 and θ = π where ``vect(R − Rᵀ)/(2 sin θ)``
    does not. At θ = 0 the axis is arbitrary and returned as ``(0, 0, 1)``; at θ = π both ``±n`` describe
    ``R``, and the one returned is SciPy's choice.
    """
    R = _as_rotations(R)
    rotvec = _as_scipy(R).as_rotvec().reshape(R.shape[:-2] + (3,))
    theta = np.linalg.norm(rotvec, axis=-1)
    safe = np.where(theta > 0, theta, 1.0)[..., None]
    axis = np.where(theta[..., None] > 0, rotvec / safe, np.array([0.0, 0.0, 1.0]))
    return axis, theta


def log(R) -> np.ndarray:
    """Rotation vector ``θ n`` of ``R`` (the matrix logarithm as a 3-vector), ``(..., 3)``."""
    axis, theta = axis_angle(R)
    return axis * theta[..., None]


def exp(rotvec) -> np.ndarray:
    """Rotation matrix of the rotation vector ``θ n``, ``(..., 3, 3)``."""
    rotvec = np.asarray(rotvec, dtype=float)
    return Rotation.from_rotvec(rotvec.reshape(-1, 3)).as_matrix().reshape(rotvec.shape[:-1] + (3, 3))


def from_euler_zxz(angles) -> np.ndarray:
    """``R3(α) R1(β) R3(γ)`` from ``angles = (..., 3)`` holding ``(α, β, γ)``, the convention of eq. (8)."""
    return _from_euler("ZXZ", angles)


def to_euler_zxz(R) -> np.ndarray:
    """``(α, β, γ)`` with ``R = R3(α) R1(β) R3(γ)``, ``β ∈ [0, π]``, ``α, γ ∈ (−π, π]``; shape ``(..., 3)``."""
    return _to_euler("ZXZ", R)


def from_euler_zyz(angles) -> np.ndarray:
    """``R3(α) R2(β) R3(γ)`` from ``(..., 3)`` angles, the convention of eq. (9)."""
    return _from_euler("ZYZ", angles)


def to_euler_zyz(R) -> np.ndarray:
    """``(α, β, γ)`` with ``R = R3(α) R2(β) R3(γ)``; shape ``(..., 3)``."""
    return _to_euler("ZYZ", R)


def _from_euler(seq: str, angles) -> np.ndarray:
    angles = np.asarray(angles, dtype=float)
    if angles.shape[-1:] != (3,) or not np.all(np.isfinite(angles)):
        raise bad_value("angles", "finite Euler angles of shape (..., 3)", f"shape {angles.shape}")
    flat = Rotation.from_euler(seq, angles.reshape(-1, 3)).as_matrix()
    return flat.reshape(angles.shape[:-1] + (3, 3))


def _to_euler(seq: str, R) -> np.ndarray:
    R = _as_rotations(R)
    with warnings.catch_warnings():  # gimbal lock: SciPy sets γ = 0 and warns; the result is still exact
        warnings.simplefilter("ignore", UserWarning)
        flat = _as_scipy(R).as_euler(seq)
    return flat.reshape(R.shape[:-2] + (3,))


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
    R1 = _as_rotations(R1, "R1")
    R2 = _as_rotations(R2, "R2")
    t = np.asarray(t, dtype=float)
    omega = log(np.swapaxes(R1, -1, -2) @ R2)
    return R1 @ exp(omega * t[..., None])


def path_length(keys) -> float:
    """Length of the piecewise-geodesic path through ``keys`` ``(m, 3, 3)``: the sum of Park distances."""
    keys = _as_rotations(keys, "path")
    return float(np.sum(distance(keys[:-1], keys[1:])))


def resample(path, n: int) -> np.ndarray:
    """``n + 1`` rotations on the piecewise-geodesic path through ``path`` ``(m, 3, 3)`` with equal steps.

    The first and last rotations are the path's ends, and consecutive rotations are at one common Park
    distance ``h``: ``D(R_{i−1}, R_i) = D(R_i, R_{i+1})`` (Sec. III-A). On a single geodesic this is equal arc
    length; across a corner of the path the chord is shorter than the arc, so ``h`` is found by shooting: for a
    trial ``h`` each next rotation is the first point further along the path at distance ``h`` from the last
    one (a closed-form trigonometric equation on each segment), and ``h`` is adjusted (Brent) until the n-th
    rotation lands on the end. Consecutive keys must be less than π apart (otherwise the geodesic between
    them is not unique); a full turn is given as several keys.
    """
    keys = _as_rotations(path, "path")
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
    end = keys[-1]
    moving = seg > 0  # drop repeated keys
    keys, omegas, seg = keys[:-1][moving], omegas[moving], seg[moving]
    total = float(seg.sum())
    if total == 0.0:
        return np.repeat(end[None], n + 1, axis=0)

    def point(s_index: int, t: float) -> np.ndarray:
        return keys[s_index] @ exp(omegas[s_index] * t)

    def walk(h: float, record: bool = False):
        """From the path's start take n steps of Park distance h; return arc length left after the last one."""
        j, t = 0, 0.0  # segment index and fraction along it of the current rotation
        current = keys[0]
        points = [current]
        for _ in range(n):
            found = None
            while j < len(seg):
                t_next = _next_at_distance(current, keys[j], omegas[j], seg[j], t, h)
                if t_next is not None:
                    found = t_next
                    break
                j, t = j + 1, 0.0
            if found is None:
                return -np.inf, points  # ran off the end: h too large
            t = found
            current = point(j, t)
            if record:
                points.append(current)
        remaining = (1.0 - t) * seg[j] + seg[j + 1:].sum()
        return remaining, points

    def shortfall(h: float) -> float:
        remaining = walk(h)[0]
        return remaining if np.isfinite(remaining) else -total

    h0 = total / n  # the chord never exceeds the arc, so h <= total/n, with equality on one geodesic
    if len(seg) == 1 or abs(shortfall(h0)) <= 1e-12 * total:
        h = h0
    else:
        h = brentq(shortfall, h0 * 1e-3, h0, xtol=1e-15, rtol=1e-14, maxiter=200)
    _, points = walk(h, record=True)
    out = np.array(points)
    out[-1] = end
    return out


def _next_at_distance(Q, A, omega, length, t0, h):
    """Smallest ``t ∈ (t0, 1]`` with ``D(Q, A exp(t ω)) = h``, or None.

    With unit skew ``K`` of ``ω`` and ``φ = t·|ω|``, ``tr(Qᵀ A exp(φK)) = a + b sin φ + c (1 − cos φ)`` where
    ``M = QᵀA``, ``a = tr M``, ``b = tr(M K)``, ``c = tr(M K²)``; setting it to ``1 + 2 cos h`` gives
    ``b sin φ − c cos φ = 1 + 2 cos h − a − c``, solved in closed form.
    """
    K = skew(omega / length)
    M = Q.T @ A
    a, b, c = np.trace(M), np.trace(M @ K), np.trace(M @ K @ K)
    rhs = 1.0 + 2.0 * np.cos(h) - a - c
    amp = np.hypot(b, c)
    if amp == 0 or abs(rhs) > amp * (1 + 1e-12):
        return None
    # b sin φ − c cos φ = amp sin(φ − ψ) with ψ = atan2(c, b)
    psi = np.arctan2(c, b)
    base = np.arcsin(np.clip(rhs / amp, -1.0, 1.0))
    phi0 = t0 * length
    candidates = []
    for root in (base + psi, np.pi - base + psi):
        root = np.mod(root - phi0, 2 * np.pi) + phi0
        if root <= phi0 + 1e-15:
            root += 2 * np.pi
        if root <= length * (1 + 1e-12):
            candidates.append(root)
    if not candidates:
        return None
    return min(min(candidates) / length, 1.0)
