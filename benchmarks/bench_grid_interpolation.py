"""The alternative the fast-path issue names, measured against the fast path: the rotor function and its torque
density tabulated once on a fine grid on the sphere and interpolated (docs/potential.md, "What is left and why").

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_grid_interpolation.py``.

What is tabulated: ``F`` and the torque density ``T = x × ∇F`` (3 components), each band-limited to the
potential's degree ``L`` (the angular-momentum operator keeps degrees), on the double Fourier sphere
``(θ, φ) ∈ [0, 2π)²`` — a trigonometric polynomial of degree ``L`` in both angles. Coefficients from ducc0's exact
syntheses on an ``n × n`` grid (``n = 2L + 2``, ``θ`` shifted by half a spacing), one FFT, divided by the
"exponential of semicircle" kernel's transform and zero-padded to ``N = 2n`` (a type-2 NUFFT's set-up, done once
per design). Two evaluators of the same coefficients at the coils' body-frame directions, 1000 random
orientations × 29 coils, one thread:

* compiled (numba): ``w × w`` taps per point, the kernel's weights as degree-15 polynomials (Horner);
* ducc0's ``nufft.u2nu`` (two complex transforms carry the four real fields), at ``epsilon`` 1e-10.

Printed per evaluator: µs per orientation (median of 5, energy and torque of 29 coils, positions included for
the compiled one, excluded for ducc0's), the largest error of each field relative to its peak (against ducc0's
synthesis at 20,000 random points), beside the fast path's energy + torque (``MotorPotential.energy_and_torque``)
and ducc0's synthesis of ``F`` alone (the anchor) in the same run.
"""

from __future__ import annotations

import datetime
import math
import os
import platform

import numpy as np
from numba import njit

from _timing import median_seconds
from spherestep import so3
from spherestep._fast.synthesis import locations
from spherestep.motor import prototype
from spherestep.potential import MotorPotential

DEGREE = 15  # the kernel weights' polynomial degree in the offset
BETA_PER_WIDTH = 2.30  # ES kernel shape for oversampling 2 (Barnett, Magland & af Klinteberg 2019)


def es_kernel(d, width):
    """``ψ(d) = exp(β(√(1 − (2d/w)²) − 1))`` for ``|d| ≤ w/2`` (grid spacings), else 0."""
    z = 2.0 * np.asarray(d, dtype=float) / width
    inside = np.abs(z) <= 1.0
    return np.where(inside, np.exp(BETA_PER_WIDTH * width * (np.sqrt(np.where(inside, 1 - z * z, 0.0)) - 1)), 0.0)


def exact_fields(field, x):
    """``(P, 4)``: ``F`` and ``T = x × g`` at unit vectors ``x`` by ducc0's synthesis."""
    F, g, _ = field.fields(x, 1, method="ducc0")
    return np.column_stack([F, np.cross(x, g)])


def fourier_coefficients(field):
    """The four fields' double-Fourier-sphere coefficients ``(n, n, 4)`` (FFT order) and their frequencies."""
    n = 2 * field.lmax + 2
    theta, phi = 2 * np.pi * (np.arange(n // 2) + 0.5) / n, 2 * np.pi * np.arange(n) / n
    x = np.stack(np.broadcast_arrays(np.sin(theta)[:, None] * np.cos(phi), np.sin(theta)[:, None] * np.sin(phi),
                                     np.cos(theta)[:, None]), axis=-1).reshape(-1, 3)
    half = exact_fields(field, x).reshape(n // 2, n, 4)
    full = np.concatenate([half, np.roll(half, -n // 2, axis=1)[::-1]], axis=0)  # f(2π − θ, φ) = f(θ, φ + π)
    k = np.fft.fftfreq(n, 1.0 / n)
    return np.fft.fft2(full, axes=(0, 1)) / n**2 * np.exp(-1j * k * np.pi / n)[:, None, None], k


def grid(coeffs, k, L, width):
    """The deconvolved, oversampled grid ``(rows, cols, 4)`` (``θ`` rows from −w to N/2 + w, ``φ`` columns from −w
    to N + w) and the weights' polynomials ``(DEGREE + 1, w)`` in ``z = 2u − 1``."""
    N = 2 * len(k)
    nodes, weights = np.polynomial.legendre.leggauss(8 * width)
    d = 0.5 * width * nodes
    keep = np.abs(k) <= L
    psi = 0.5 * width * (np.cos(2 * np.pi * np.multiply.outer(k[keep], d) / N) @ (weights * es_kernel(d, width)))
    padded = np.zeros((N, N, 4), dtype=complex)
    idx = k[keep].astype(int) % N
    padded[np.ix_(idx, idx)] = coeffs[np.ix_(keep, keep)] / (psi[:, None, None] * psi[None, :, None])
    values = np.fft.ifft2(padded, axes=(0, 1)).real * N**2
    stored = np.ascontiguousarray(values[np.ix_(np.arange(-width, N // 2 + width + 1) % N,
                                               np.arange(-width, N + width + 1) % N)])
    z = np.cos(np.pi * (np.arange(4 * DEGREE) + 0.5) / (4 * DEGREE))
    poly = np.empty((DEGREE + 1, width))
    for m in range(width):
        cheb = np.polynomial.chebyshev.chebfit(z, es_kernel(0.5 * (z + 1) + 0.5 * width - 1 - m, width), DEGREE)
        poly[:, m] = np.polynomial.chebyshev.cheb2poly(cheb)[::-1]
    return stored, poly, N / (2 * np.pi)


@njit(cache=True, fastmath=True)
def _weights(poly, s, out):
    f = math.floor(s)
    z = 2.0 * (s - f) - 1.0
    for m in range(out.shape[0]):
        out[m] = poly[0, m]
    for d in range(1, poly.shape[0]):
        for m in range(out.shape[0]):
            out[m] = out[m] * z + poly[d, m]
    return int(f)


@njit(cache=True, fastmath=True)
def _at(table, poly, scale, x0, x1, x2, wt, wp):
    theta = math.atan2(math.sqrt(x0 * x0 + x1 * x1), x2)
    phi = math.atan2(x1, x0)
    if phi < 0.0:
        phi += 2.0 * math.pi
    width = wt.shape[0]
    i0 = _weights(poly, theta * scale, wt) + width // 2 + 1
    j0 = _weights(poly, phi * scale, wp) + width // 2 + 1
    a0 = a1 = a2 = a3 = 0.0
    for a in range(width):
        r0 = r1 = r2 = r3 = 0.0
        for b in range(width):
            wb = wp[b]
            r0 += wb * table[i0 + a, j0 + b, 0]
            r1 += wb * table[i0 + a, j0 + b, 1]
            r2 += wb * table[i0 + a, j0 + b, 2]
            r3 += wb * table[i0 + a, j0 + b, 3]
        wa = wt[a]
        a0 += wa * r0
        a1 += wa * r1
        a2 += wa * r2
        a3 += wa * r3
    return a0, a1, a2, a3


@njit(cache=True)
def interpolate(table, poly, scale, x, out):
    wt, wp = np.empty(poly.shape[1]), np.empty(poly.shape[1])
    for p in range(x.shape[0]):
        out[p, 0], out[p, 1], out[p, 2], out[p, 3] = _at(table, poly, scale, x[p, 0], x[p, 1], x[p, 2], wt, wp)


@njit(cache=True)
def energy_and_torque(table, poly, scale, R, coils, c, E, torque):
    """``E[q] = Σ_k c_k F(x_k)``, ``torque[q] = R Σ_k c_k T(x_k)``, ``x_k = R_qᵀ v_k`` (the model's sign left out)."""
    wt, wp = np.empty(poly.shape[1]), np.empty(poly.shape[1])
    for q in range(R.shape[0]):
        e = t0 = t1 = t2 = 0.0
        for k in range(coils.shape[0]):
            v0, v1, v2 = coils[k, 0], coils[k, 1], coils[k, 2]
            x0 = R[q, 0, 0] * v0 + R[q, 1, 0] * v1 + R[q, 2, 0] * v2
            x1 = R[q, 0, 1] * v0 + R[q, 1, 1] * v1 + R[q, 2, 1] * v2
            x2 = R[q, 0, 2] * v0 + R[q, 1, 2] * v1 + R[q, 2, 2] * v2
            f, s0, s1, s2 = _at(table, poly, scale, x0, x1, x2, wt, wp)
            e += c[k] * f
            t0 += c[k] * s0
            t1 += c[k] * s1
            t2 += c[k] * s2
        E[q] = e
        for a in range(3):
            torque[q, a] = R[q, a, 0] * t0 + R[q, a, 1] * t1 + R[q, a, 2] * t2


def positions(x):
    """``(θ, φ)`` of unit vectors ``x`` as ducc0 takes them (:func:`spherestep._fast.synthesis.locations`)."""
    loc = np.empty((len(x), 2))
    locations(np.ascontiguousarray(x), loc)
    return loc


def main() -> None:
    import ducc0

    rng = np.random.default_rng(0)
    design = prototype()
    model = MotorPotential(design)
    field = model.rotor_field
    R, c = so3.random(1000, rng), rng.uniform(-1.0, 1.0, len(design.stator))
    points = rng.normal(size=(20_000, 3))
    points /= np.linalg.norm(points, axis=1, keepdims=True)
    reference = exact_fields(field, points)
    peak = np.abs(reference).max(axis=0)
    coeffs, k = fourier_coefficients(field)

    rows = [("fast path, energy + torque (ducc0 syntheses, compiled glue)",
             median_seconds(5, model.energy_and_torque, R, c), float("nan"))]
    x = np.einsum("qba,kb->qka", R, model.coils).reshape(-1, 3)  # every coil's body-frame direction
    loc = positions(x)
    anchor = median_seconds(5, field.synthesis, loc)
    rows.append(("ducc0 synthesis of F alone (the anchor)", anchor, float("nan")))
    for width in (10, 12):
        table, poly, scale = grid(coeffs, k, field.lmax, width)
        out = np.empty((len(points), 4))
        interpolate(table, poly, scale, points, out)
        E, torque = np.empty(len(R)), np.empty((len(R), 3))
        seconds = median_seconds(5, energy_and_torque, table, poly, scale, R, model.coils, c, E, torque)
        rows.append((f"grid, compiled, {width} taps", seconds, float(np.max(np.abs(out - reference).max(0) / peak))))
    keep = np.abs(k) <= field.lmax
    shifted = np.fft.fftshift(coeffs[np.ix_(keep, keep)], axes=(0, 1))  # frequencies −L..L, as u2nu takes them
    packed = np.ascontiguousarray(np.stack([shifted[..., 0] + 1j * shifted[..., 1],
                                            shifted[..., 2] + 1j * shifted[..., 3]]))

    def nufft(where):
        return ducc0.nufft.u2nu(grid=packed, coord=where, forward=False, epsilon=1e-10, nthreads=1)

    check = nufft(positions(points))
    got = np.column_stack([check[0].real, check[0].imag, check[1].real, check[1].imag])
    rows.append(("grid, ducc0 nufft.u2nu (epsilon 1e-10)", median_seconds(5, nufft, loc),
                 float(np.max(np.abs(got - reference).max(0) / peak))))

    print(f"bench_grid_interpolation — {datetime.date.today()}, {platform.machine()}, {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.1f}, OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}")
    print(f"prototype, L = {field.lmax}; 1000 orientations × 29 coils")
    print(f"{'evaluator':<62} {'µs/orient.':>10} {'vs anchor':>9} {'max err/peak':>13}")
    for name, seconds, error in rows:
        print(f"{name:<62} {seconds / len(R) * 1e6:>10.2f} {seconds / anchor:>8.2f}x {error:>13.1e}")


if __name__ == "__main__":
    main()
