"""Timings of spherestep.harmonics against simple baselines measured in the same run (medians of repeats).

Run: ``.venv/bin/python benchmarks/bench_harmonics.py [--json PATH]``. Baselines:

* P^l matrix: the elementwise three-term recurrence in l (``legendre_P`` broadcast over all m, n), and Wigner's
  explicit sum evaluated naively in floating point (with ``lgamma``); both on fewer angles, scaled per angle.
* wigner_U: the same function called once per rotation in a Python loop.
* S² transform: a dense matrix of all Y_l^m at all grid points (built once, outside the timing), one product.
* SO(3) transform: brute-force quadrature of eq. (14) with ``wigner_U`` at every grid rotation.
"""

from __future__ import annotations

import datetime
import os
import platform

import numpy as np
import scipy
from scipy.special import gammaln, sph_harm_y

from _record import Record
from _timing import median_seconds
from spherestep import so3
from spherestep.harmonics import (
    legendre_P,
    legendre_P_matrix,
    s2_forward,
    s2_grid,
    s2_inverse,
    so3_forward,
    so3_grid,
    so3_inverse,
    wigner_U,
)


def per_rotation(l: int, rotations: np.ndarray) -> list:
    return [wigner_U(l, Rk) for Rk in rotations]


def brute_so3_forward(f: np.ndarray, grid) -> list:
    """Eq. (14) by quadrature: ``f̂^l_mn = Σ_k w_k f(R_k) conj U^l_nm(R_k)`` for each ``l``."""
    rotations = grid.rotations().reshape(-1, 3, 3)
    weighted = grid.weights.ravel() * f.ravel()
    return [np.einsum("k,knm->mn", weighted, np.conj(wigner_U(l, rotations))) for l in range(grid.lmax + 1)]


def naive_wigner_sum(l: int, beta: np.ndarray) -> np.ndarray:
    """``(−1)^(m−n) d^l_mn(β)`` from Wigner's explicit sum in float64: exact in theory, cancels in practice."""
    m = np.arange(-l, l + 1)[:, None, None]
    n = np.arange(-l, l + 1)[None, :, None]
    k = np.arange(0, 2 * l + 1)[None, None, :]
    valid = (l + n - k >= 0) & (k >= 0) & (m - n + k >= 0) & (l - m - k >= 0)
    safe = np.where(valid, 1, 0)
    log_coef = 0.5 * (gammaln(l + m + 1) + gammaln(l - m + 1) + gammaln(l + n + 1) + gammaln(l - n + 1)) - (
        gammaln(np.where(valid, l + n - k, 0) + 1) + gammaln(k * safe + 1)
        + gammaln(np.where(valid, m - n + k, 0) + 1) + gammaln(np.where(valid, l - m - k, 0) + 1))
    sign = np.where((m - n + k) % 2 == 0, 1.0, -1.0) * np.where((m - n) % 2 == 0, 1.0, -1.0)
    p_cos = np.where(valid, 2 * l + n - m - 2 * k, 0)
    p_sin = np.where(valid, m - n + 2 * k, 0)
    c = np.cos(beta / 2)[:, None, None, None]
    s = np.sin(beta / 2)[:, None, None, None]
    terms = np.where(valid, sign * np.exp(log_coef) * c**p_cos * s**p_sin, 0.0)
    return terms.sum(axis=-1)


def main() -> None:
    record = Record("harmonics")  # --json PATH: the rows below stored for scripts/docs_numbers.py
    rng = np.random.default_rng(0)
    rows = []

    for l in (32, 64):
        x = rng.uniform(-1, 1, 1000)
        ours = median_seconds(7, legendre_P_matrix, l, x)
        few = x[:50]
        mm, nn = np.meshgrid(np.arange(-l, l + 1), np.arange(-l, l + 1), indexing="ij")
        recurrence = median_seconds(3, legendre_P, l, mm, nn, few[:, None, None]) * len(x) / len(few)
        error = np.max(np.abs(legendre_P(l, mm, nn, few[:, None, None]) - legendre_P_matrix(l, few)))
        rows.append((f"P^l matrix, l={l}, 1000 angles", ours, "recurrence in l (elementwise)", recurrence, error))
        naive = median_seconds(3, naive_wigner_sum, l, np.arccos(few[:10])) * len(x) / 10
        error = np.max(np.abs(naive_wigner_sum(l, np.arccos(few[:10])) - legendre_P_matrix(l, few[:10])))
        rows.append((f"P^l matrix, l={l}, 1000 angles", ours, "Wigner's explicit sum (float)", naive, error))

    R = so3.random(1000, rng)
    for l in (32, 64):
        ours = median_seconds(5, wigner_U, l, R)
        loop = median_seconds(3, per_rotation, l, R[:100]) * 10
        error = np.max(np.abs(np.array(per_rotation(l, R[:20])) - wigner_U(l, R[:20])))
        rows.append((f"wigner_U, l={l}, 1000 rotations", ours, "one call per rotation", loop, error))

    for lmax in (32, 64):
        grid = s2_grid(lmax)
        f = rng.normal(size=(lmax + 1, 2 * lmax + 1))
        ours = median_seconds(9, s2_forward, f)
        ls = np.concatenate([[l] * (2 * l + 1) for l in range(lmax + 1)])
        ms = np.concatenate([np.arange(-l, l + 1) for l in range(lmax + 1)])
        t, p = np.meshgrid(grid.theta, grid.phi, indexing="ij")
        dense = np.conj(sph_harm_y(ls[:, None], ms[:, None], t.ravel()[None], p.ravel()[None])) * grid.weights.ravel()
        baseline = median_seconds(5, np.matmul, dense, f.ravel())
        flm = s2_forward(f)
        error = np.max(np.abs(dense @ f.ravel() - flm[ls, ms + lmax]))
        rows.append((f"S² forward, L={lmax}", ours, "dense Y matrix product", baseline, error))
        ours_inv = median_seconds(9, s2_inverse, flm)
        rows.append((f"S² inverse, L={lmax}", ours_inv, "", float("nan"), float("nan")))

    for lmax in (16, 32):
        grid = so3_grid(lmax)
        f = rng.normal(size=(2 * lmax + 1, lmax + 1, 2 * lmax + 1))
        ours = median_seconds(3, so3_forward, f)
        fhat = so3_forward(f)
        inverse = median_seconds(3, so3_inverse, fhat)
        if lmax == 16:
            baseline = median_seconds(1, brute_so3_forward, f, grid)
            error = max(np.max(np.abs(block - fhat[l, lmax - l:lmax + l + 1, lmax - l:lmax + l + 1]))
                        for l, block in enumerate(brute_so3_forward(f, grid)))
            rows.append((f"SO(3) forward, L={lmax}", ours, "quadrature with wigner_U at each grid point", baseline,
                         error))
        else:
            rows.append((f"SO(3) forward, L={lmax}", ours, "", float("nan"), float("nan")))
        rows.append((f"SO(3) inverse, L={lmax}", inverse, "", float("nan"), float("nan")))

    print(f"spherestep.harmonics benchmarks — {datetime.date.today()}, {platform.machine()}, {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.1f}, Python {platform.python_version()}, NumPy {np.__version__}, "
          f"SciPy {scipy.__version__}")
    print(f"{'task':<34} {'ours [ms]':>10}  {'baseline':<44} {'baseline [ms]':>13} {'ratio':>8} {'max |diff|':>11}")
    for task, ours, name, baseline, error in rows:
        ratio = baseline / ours if np.isfinite(baseline) else float("nan")
        print(f"{task:<34} {ours * 1e3:>10.2f}  {name:<44} {baseline * 1e3:>13.1f} {ratio:>8.1f} {error:>11.1e}")
        record.values.setdefault("rows", []).append({"task": task, "s": ours, "baseline": name, "baseline s": baseline,
                                                     "max diff": error})
    record.write()


if __name__ == "__main__":
    main()
