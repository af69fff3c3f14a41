"""The rotor as one function on the sphere: ``F(x) = Σ_j p_j h(x · u_j)``, its gradient and Hessian, fast.

Why. Every torque model whose pole–coil interaction depends only on the angle between a pole's axis and a
coil's axis (the potential of Sec. III-B, the magnets' torque map) has an energy of the form

    E(R, c) = E_0(c) + s Σ_k c_k F(x_k),   x_k = Rᵀ v_k (coil k's direction in the rotor's body frame),

with ``F(x) = Σ_j p_j h(x · u_j)`` one function on the sphere, fixed per design (``s`` a model constant: −2 for
the potential, +1 for the map). So the energy of 29 coils is 29 values of one function, not 29 × M pair terms.

Derivatives. Turn the rotor by ``R → exp(θ̂) R`` (``θ`` in the fixed frame). Then ``x_k → Rᵀ exp(−θ̂) v_k`` and,
with ``g(x) = (I − x xᵀ) ∇F`` the tangential gradient and ``Hess F`` the intrinsic (covariant) Hessian on the
sphere (tangent 3×3 matrices, ``Hess F = P M P − (x·∇F) P`` with ``M`` the ambient second derivative of the
extension ``Σ p_j h(y·u_j)``, ``P = I − x xᵀ``),

    τ = −∂E/∂θ = s R Σ_k c_k x_k × g(x_k),
    K(R)[:, k] = s R (x_k × g(x_k))                       (torque per unit current, the torque matrix),
    H = ∂²E/∂θ² = s R [Σ_k c_k (ΔF(x_k) P_k − Hess F(x_k) + ½(g_k x_kᵀ + x_k g_kᵀ))] Rᵀ,

where ``ΔF = tr Hess F`` is the Laplace–Beltrami operator (``[x]×ᵀ A [x]× = (tr A) P − A`` for a tangent
symmetric ``A`` turns the Hessian's ``[x]×ᵀ Hess F [x]×`` into the bracket above).

Two evaluators return the same fields (``F``, ``g``, ``Hess F`` at unit vectors ``x``):

* ``"ducc0"``: for a band-limited ``F`` (degree ``lmax``: the potential, whose kernel is a Legendre series of
  degree ``L``, so the representation is exact). Its coefficients ``f_lm`` come once
  from exact samples on a Gauss–Legendre grid (:func:`ducc0.sht.experimental.analysis_2d`). Each call then
  synthesises at the points with :func:`ducc0.sht.synthesis_general` (non-uniform FFT, accuracy ``epsilon``):
  spin 0 for ``F``; spin 1 (``DERIV1``, the gradient ``(∂_θ F, ∂_φ F / sin θ)``) for ``g``; for the Hessian
  spin 0 with ``−l(l+1) f_lm`` (``ΔF``) and spin 2 with ``√((l−1)l(l+1)(l+2)) f_lm`` (the trace-free part,
  ``ð²F``, in the ``θ̂, φ̂`` basis). Each synthesis has a fixed cost (a Legendre transform and an FFT of about
  ``(2 lmax)²`` points, ~0.7 ms for ``lmax = 68``) and then ~0.15 µs per point, so it wins for large batches;
  there the points' positions and the sums over the coils run compiled (:mod:`spherestep._fast.synthesis`:
  ``pair_locations``, ``synthesis_sums``, ``synthesis_columns``; ``synthesis_fields`` for :meth:`fields`).
* ``"direct"``: the sum over the poles with the model's own kernel ``h, h', h''`` (``O(M)`` per point, no
  fixed cost) — compiled (:mod:`spherestep._fast.kernels`, numba) when the kernel comes in one of its compiled
  forms, NumPy otherwise: used below ``direct_below`` points, where it is faster, for fields given without ``lmax``
  (the torque map: its spline kernel is not band-limited, and its harmonic series converges slowly — with
  ``lmax = 384`` still 7e-5 of the peak torque off), and as the reference of the harmonic evaluator.

``nthreads`` (ducc0's threads) is set deliberately: 1 by default (one core per process on a shared machine);
results do not depend on it beyond rounding.
"""

from __future__ import annotations

import math

import numpy as np

from . import checks
from ._fast import Packed
from .errors import bad_value

# the compiled sums leave out poles whose terms of h, h', h'' are all below these shares of their peaks (h'' is
# itself tabulated to ~1e-9 of its peak and h' to ~1e-11: spherestep.potential.kernel)
CUTOFF_TAILS = (1e-13, 1e-12, 1e-10)
# points: below these the direct sum is faster than ducc0's synthesis, in NumPy and compiled (measured for the
# prototype, L = 68: compiled 0.71 µs per point for F and g against ducc0's 0.69 at 6,400 points, 1.0 at 3,200)
DIRECT_BELOW, COMPILED_DIRECT_BELOW = 400, 8000
SPIN2_SIGN = -1.0  # ducc0's spin-2 (Q, U) are minus the trace-free Hessian's (θθ − φφ, 2θφ) parts (tests/test_fast_path.py)


_NEXT, _PREV = np.array([1, 2, 0]), np.array([2, 0, 1])
_FIRST = np.zeros(1, dtype=np.intp)
_EMPTY = np.empty(0)  # an unused argument of the compiled loops


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a × b`` over the last axis (broadcasting), in seven NumPy calls (``np.cross`` costs more per call)."""
    return a[..., _NEXT] * b[..., _PREV] - a[..., _PREV] * b[..., _NEXT]


class RotorField:
    """``F(x) = Σ_j p_j h(x · u_j)`` on the unit sphere with its tangential gradient and intrinsic Hessian.

    ``poles (M, 3)`` unit vectors ``u_j`` and ``polarity (M,)`` ``p_j`` (body frame); ``kernel(t, orders)`` returns
    the derivatives of ``h`` of the given ``orders`` (a tuple from 0, 1, 2) at ``t`` (any shape), used by the
    direct evaluator; ``compiled``: the same ``h`` as ``(kind, params)`` of :mod:`spherestep._fast.kernels`
    (``"quintic"`` or ``"angle_spline"``), which makes the direct sum compiled.
    With ``lmax``: the ducc0 evaluator; ``exact(t)`` (default ``kernel(t, (0,))[0]``) the most accurate ``h``,
    used once to sample ``F`` for its spherical-harmonic coefficients up to degree ``lmax`` on a
    Gauss–Legendre grid of ``rings ≥ lmax + 1`` rings; ``epsilon``: ducc0's synthesis accuracy; ``nthreads``:
    ducc0's threads. Without ``lmax``, only the direct sum. ``direct_below``: batches of fewer points use the
    direct sum (see the module docstring).
    """

    def __init__(self, poles, polarity, kernel, lmax: int | None = None, *, exact=None, rings: int | None = None,
                 epsilon: float = 1e-13, nthreads: int = 1, direct_below: int | None = None, compiled=None):
        self.poles = np.ascontiguousarray(poles, dtype=float)
        self.poles_t = np.ascontiguousarray(self.poles.T)  # (3, M): the compiled sums' layout
        self.polarity = np.ascontiguousarray(polarity, dtype=float)
        self.polarity_row = self.polarity[None]  # (1, M): one term's pole weights
        self._single = None
        self.kernel = kernel
        self.compiled = None
        self.cut = None
        if compiled is not None:
            from ._fast.kernels import kernel_params

            kind, arrays = compiled
            if kind not in ("quintic", "angle_spline", "sphere_table"):
                raise bad_value("compiled", "a kernel kind 'quintic', 'angle_spline' or 'sphere_table'", kind)
            # a "sphere_table" is F itself tabulated (spherestep._fast.spheretable): no poles to cut
            self.cut = None if kind == "sphere_table" else cutoff(kernel, self.polarity, CUTOFF_TAILS)
            self.compiled = kernel_params(kind, arrays, -2.0 if self.cut is None else math.cos(self.cut))
        self.lmax = None if lmax is None else int(lmax)
        self.epsilon = float(epsilon)
        self.nthreads = threads(nthreads)
        if direct_below is None:
            direct_below = DIRECT_BELOW if compiled is None else COMPILED_DIRECT_BELOW
        self.direct_below = int(direct_below)
        self._pu = self.polarity[:, None] * self.poles  # p_j u_j
        self._puu = (self._pu[:, :, None] * self.poles[:, None, :]).reshape(-1, 9)  # p_j u_j u_jᵀ, flattened
        if self.lmax is not None:
            self._build_harmonic(exact, rings)

    @property
    def single(self) -> tuple:
        """The compiled single-orientation call and its fixed arguments, ``(terms_evaluate, params, offsets,
        poles (3, M), polarity (1, M), *scratch)`` (:func:`spherestep._fast.terms.workspace`), gathered once: a
        call's Python overhead is most of its cost."""
        if self._single is None:
            from ._fast.terms import terms_evaluate, workspace

            self._single = (terms_evaluate, self.compiled, _OFFSETS[len(self.compiled)], self.poles_t,
                            self.polarity_row, *workspace(self.poles_t))
        return self._single

    def _build_harmonic(self, exact, rings) -> None:
        import ducc0

        kernel = self.kernel
        rings = self.lmax + 1 if rings is None else int(rings)
        if rings < self.lmax + 1:
            raise bad_value("rings", f"at least lmax + 1 = {self.lmax + 1}", rings)
        h = (lambda t: kernel(t, (0,))[0]) if exact is None else exact
        nodes = np.polynomial.legendre.leggauss(rings)[0][::-1]  # cos θ, θ ascending (ducc0's GL order)
        phi = 2 * np.pi * np.arange(2 * self.lmax + 2) / (2 * self.lmax + 2)
        sin = np.sqrt(1.0 - nodes**2)
        grid = np.stack(np.broadcast_arrays(sin[:, None] * np.cos(phi), sin[:, None] * np.sin(phi),
                                            nodes[:, None]), axis=-1)
        values = h(np.clip(grid @ self.poles.T, -1.0, 1.0)) @ self.polarity
        self.alm = ducc0.sht.experimental.analysis_2d(map=values[None], spin=0, lmax=self.lmax, geometry="GL",
                                                      nthreads=self.nthreads)
        degrees = np.concatenate([np.arange(m, self.lmax + 1) for m in range(self.lmax + 1)])  # healpy order
        self._laplacian_alm = self.alm * (-degrees * (degrees + 1.0))
        self._spin2_alm = self.alm * np.sqrt(np.maximum((degrees - 1.0) * degrees * (degrees + 1) * (degrees + 2),
                                                        0.0))

    def fields(self, x: np.ndarray, order: int = 1, value: bool = True, method: str | None = None):
        """``(F, g, Hess F)`` at unit vectors ``x (P, 3)``: ``F (P,)`` if ``value`` (else ``None``),
        ``g (P, 3)`` the tangential gradient for ``order ≥ 1``, for ``order = 2`` the pair ``(ΔF (P,),
        Hess F (P, 3, 3))``. ``method``: ``"ducc0"``, ``"direct"`` or ``None`` (the direct sum below
        ``direct_below`` points or without ``lmax``)."""
        if method is None:
            method = "direct" if self.lmax is None or len(x) < self.direct_below else "ducc0"
        if method == "direct":
            return self._direct(x, order, value)
        if method == "ducc0" and self.lmax is not None:
            return self._harmonic(x, order, value)
        raise bad_value("method", "'direct', 'ducc0' (for a field built with lmax) or None", method)

    # --- direct sum over the poles -----------------------------------------------------------------------
    def _direct(self, x: np.ndarray, order: int, value: bool):
        if self.compiled is not None:
            return self._compiled(x, order, value)
        t = x @ self.poles.T  # (P, M)
        orders = tuple(range(0 if value else 1, order + 1))
        hs = dict(zip(orders, self.kernel(t, orders)))
        F = hs[0] @ self.polarity if value else None
        if order == 0:
            return F, None, None
        S = hs[1] @ self._pu  # ambient gradient Σ p h'(t) u
        radial = np.sum(S * x, axis=-1)
        g = S - radial[:, None] * x
        if order == 1:
            return F, g, None
        M = (hs[2] @ self._puu).reshape(-1, 3, 3)  # Σ p h'' u uᵀ
        P = np.eye(3) - x[:, :, None] * x[:, None, :]
        hess = P @ M @ P - radial[:, None, None] * P
        return F, g, (np.trace(hess, axis1=1, axis2=2), hess)

    def _compiled(self, x: np.ndarray, order: int, value: bool):
        from ._fast.kernels import zonal_fields

        P = len(x)
        F, g = np.empty(P), np.empty((P if order >= 1 else 0, 3))
        lap, hess = np.empty(P if order >= 2 else 0), np.empty((P if order >= 2 else 0, 3, 3))
        zonal_fields(self.compiled, np.ascontiguousarray(x, dtype=float), self.poles_t, self.polarity, order, F, g,
                     lap, hess)
        return (F if value else None), (g if order >= 1 else None), ((lap, hess) if order >= 2 else None)

    # --- spherical-harmonic synthesis (ducc0) -------------------------------------------------------------
    def synthesis(self, loc: np.ndarray, spin: int = 0, alm: np.ndarray | None = None,
                  mode: str = "STANDARD") -> np.ndarray:
        """ducc0's synthesis of ``alm`` (default ``F``'s) at ``loc (P, 2)`` (``θ, φ``): ``(spin + 1 or 1, P)``;
        ``spin = 1, mode = "DERIV1"`` gives the gradient's ``(g_θ, g_φ)``."""
        from ducc0.sht import synthesis_general

        return synthesis_general(alm=self.alm if alm is None else alm, spin=spin, mode=mode, lmax=self.lmax,
                                 loc=loc, epsilon=self.epsilon, nthreads=self.nthreads)

    def _harmonic(self, x: np.ndarray, order: int, value: bool):
        from ._fast.synthesis import locations, synthesis_fields

        x = np.ascontiguousarray(x, dtype=float)
        loc = np.empty((len(x), 2))
        locations(x, loc)
        F, d_theta, d_phi, lap, q, u = self.spin_syntheses(loc, order, value)
        if order == 0:
            return (F if value else None), None, None
        g, hess = np.empty_like(x), np.empty((len(x) if order >= 2 else 0, 3, 3))
        synthesis_fields(x, d_theta, d_phi, lap, q, u, SPIN2_SIGN, order, g, hess)
        return (F if value else None), g, ((lap, hess) if order >= 2 else None)

    def spin_syntheses(self, loc: np.ndarray, order: int, value: bool = True) -> tuple[np.ndarray, ...]:
        """``(F, g_θ, g_φ, ΔF, Q, U)`` at ``loc``: ``F`` if ``value``, the gradient for ``order ≥ 1``, the
        Laplacian and spin-2 pair for ``order = 2``; the others empty arrays."""
        F = self.synthesis(loc)[0] if value else _EMPTY
        d_theta, d_phi = self.synthesis(loc, 1, mode="DERIV1") if order >= 1 else (_EMPTY, _EMPTY)
        lap = self.synthesis(loc, 0, self._laplacian_alm)[0] if order >= 2 else _EMPTY
        q, u = self.synthesis(loc, 2, self._spin2_alm, "GRAD_ONLY") if order >= 2 else (_EMPTY, _EMPTY)
        return F, d_theta, d_phi, lap, q, u


def cutoff(kernel, polarity, tails) -> float | None:
    """The angle ``θc`` (rad) beyond which the poles' terms are negligible: for every sampled ``α ≥ θc`` (steps of
    0.05°), ``Σ_j |p_j| |h⁽ⁿ⁾(cos α)| ≤ tails[n] · max|h⁽ⁿ⁾|`` for ``n = 0, 1, 2``; ``None`` when no such angle
    exists (the magnets' pair energy tends to a constant, not to zero, so their fields keep every pole)."""
    alpha = np.linspace(0.0, math.pi, 3601)
    weight = float(np.abs(polarity).sum())
    ok = np.ones(len(alpha), dtype=bool)
    for values, tail in zip(kernel(np.cos(alpha), (0, 1, 2)), tails):
        ok &= weight * np.abs(values) <= tail * np.max(np.abs(values))
    failing = np.flatnonzero(~ok)
    if len(failing) == 0 or failing[-1] + 1 >= len(alpha):
        return None
    return float(alpha[failing[-1] + 1])


def threads(n) -> int:
    """A thread count for ducc0: an integer ≥ 1."""
    return checks.count(n, "nthreads", expected="an integer >= 1 (ducc0's threads)")


def fast_evaluate(field: RotorField, sign: float, coils: np.ndarray, R: np.ndarray, c: np.ndarray, order: int,
                  constant, value: bool = True) -> tuple[np.ndarray, ...]:
    """``(E,)``, ``(E, τ)`` or ``(E, τ, H)`` of ``E = constant + sign Σ_k c_k F(Rᵀ v_k)`` (module docstring) for
    validated ``R (..., 3, 3)`` and ``c (..., N)`` (leading axes broadcast), ``coils (N, 3)`` the ``v_k``.
    Only the (orientation, coil) pairs with a non-zero current are evaluated (a planner's batch of candidate
    activations energises a few coils each): in one compiled call (:func:`spherestep._fast.terms.batch_evaluate`)
    when the field has a compiled kernel, else through :meth:`RotorField.fields`. ``value=False`` skips ``F``
    (the returned energy is then ``None``: for callers that need only the torque)."""
    if field.compiled is not None and R.ndim == 2 and c.ndim == 1:  # one orientation: one compiled call
        evaluate, params, offsets, poles, polarity, work, near = field.single
        torque, H = np.empty(3), np.empty((3, 3))
        e = evaluate(params, offsets, R if R.flags.c_contiguous else np.ascontiguousarray(R), coils,
                     c[None] if c.flags.c_contiguous else np.ascontiguousarray(c)[None], poles, polarity,
                     _SIGNS[sign], order, torque, H, work, near)
        return (np.float64(e + constant) if value else None,) + (torque, H)[:order]
    lead = np.broadcast_shapes(R.shape[:-2], c.shape[:-1])
    Rf = (R if R.shape[:-2] == lead else np.broadcast_to(R, lead + (3, 3))).reshape(-1, 3, 3)
    cf = (c if c.shape[:-1] == lead else np.broadcast_to(c, lead + c.shape[-1:])).reshape(-1, c.shape[-1])
    pairs = np.count_nonzero(cf)
    if field.lmax is not None and pairs >= field.direct_below:
        return _synthesised(field, sign, coils, Rf, cf, order, constant, value, lead)
    if field.compiled is not None:  # fewer pairs, or no band limit: the compiled direct sum
        from ._fast.terms import batch_evaluate

        n = len(Rf)
        E, torque, H = np.empty(n), np.empty((n if order >= 1 else 0, 3)), np.empty((n if order >= 2 else 0, 3, 3))
        batch_evaluate(field.compiled, _OFFSETS[len(field.compiled)], np.ascontiguousarray(Rf), coils,
                       np.ascontiguousarray(cf, dtype=float)[:, None, :], field.poles_t, field.polarity_row,
                       _SIGNS[sign], order, E, torque, H)
        out = (E.reshape(lead) + constant if value else None,)
        return out + tuple(a.reshape(lead + a.shape[1:]) for a in (torque, H)[:order])
    energy = np.array(np.broadcast_to(constant, lead), dtype=float).reshape(-1) if value else None
    rows, cols = np.nonzero(cf)  # row-major: rows ascending
    out = [energy] + [np.zeros((len(Rf),) + shape) for shape in ((3,), (3, 3))[:order]]
    if len(rows) == 0:
        return tuple(None if a is None else a.reshape(lead + a.shape[1:]) for a in out)
    w = cf[rows, cols]
    Rp = Rf[rows]
    x = np.einsum("pba,pb->pa", Rp, coils[cols])  # x = Rᵀ v per energised pair
    F, g, second = field.fields(x, order, value)
    starts = _FIRST if len(Rf) == 1 else np.flatnonzero(np.concatenate([[True], rows[1:] != rows[:-1]]))
    present = rows[starts]
    if value:
        energy[present] += sign * np.add.reduceat(w * F, starts)
    if order >= 1:
        body = np.add.reduceat(w[:, None] * cross(x, g), starts, axis=0)
        out[1][present] = sign * np.einsum("kab,kb->ka", Rf[present], body)
    if order >= 2:
        lap, hess = second
        xx = x[:, :, None] * x[:, None, :]
        gx = g[:, :, None] * x[:, None, :]
        per = lap[:, None, None] * (np.eye(3) - xx) - hess + 0.5 * (gx + np.swapaxes(gx, -1, -2))
        Hb = np.add.reduceat(w[:, None, None] * per, starts, axis=0)
        Rq = Rf[present]
        out[2][present] = sign * (Rq @ Hb @ np.swapaxes(Rq, -1, -2))
    return tuple(None if a is None else a.reshape(lead + a.shape[1:]) for a in out)


def _synthesised(field: RotorField, sign: float, coils: np.ndarray, Rf: np.ndarray, cf: np.ndarray, order: int,
                 constant, value: bool, lead: tuple) -> tuple[np.ndarray, ...]:
    """:func:`fast_evaluate` of a large batch ``Rf (B, 3, 3)``, ``cf (B, N)`` by ducc0's syntheses at the energised
    pairs, their positions and sums in compiled loops (:func:`spherestep._fast.synthesis.pair_locations`,
    :func:`~spherestep._fast.synthesis.synthesis_sums`)."""
    from ._fast.synthesis import pair_locations, synthesis_sums

    rows, cols = np.nonzero(cf)
    x, loc = np.empty((len(rows), 3)), np.empty((len(rows), 2))
    Rc = np.ascontiguousarray(Rf)
    pair_locations(Rc, coils, rows, cols, x, loc)
    F, d_theta, d_phi, lap, q, u = field.spin_syntheses(loc, order, value)
    energy = np.array(np.broadcast_to(constant, lead), dtype=float).reshape(-1) if value else _EMPTY
    torque = np.empty((len(Rf) if order >= 1 else 0, 3))
    H = np.empty((len(Rf) if order >= 2 else 0, 3, 3))
    synthesis_sums(Rc, x, rows, cf[rows, cols], F, d_theta, d_phi, lap, q, u, SPIN2_SIGN, float(sign), order, energy,
                   torque, H)
    return (energy.reshape(lead) if value else None,) + tuple(a.reshape(lead + a.shape[1:])
                                                               for a in (torque, H)[:order])



class _Cache(dict):
    """Small constant arrays of the compiled calls, built once per key (a fast path's call should not build
    them): ``make(key)``."""

    def __init__(self, make):
        super().__init__()
        self.make = make

    def __missing__(self, key):
        value = self[key] = self.make(key)
        return value


_OFFSETS = _Cache(lambda n: np.array([0, n], dtype=np.int64))  # one kernel of length n
_SIGNS = _Cache(lambda sign: np.array([float(sign)]))  # one term's sign


def fast_torque_matrix(field: RotorField, sign: float, coils: np.ndarray, failed, R: np.ndarray) -> np.ndarray:
    """``K(R) (..., 3, N)``: column ``k`` is ``sign R (x_k × g(x_k))``, ``x_k = Rᵀ v_k``, zero for ``failed`` coils,
    for validated ``R (..., 3, 3)``."""
    lead = R.shape[:-2]
    Rf = R.reshape(-1, 3, 3)
    live = np.setdiff1d(np.arange(len(coils)), failed)
    if field.lmax is not None and len(Rf) * len(live) >= field.direct_below:  # ducc0, glued by compiled loops
        from ._fast.synthesis import pair_locations, synthesis_columns

        rows, cols = np.repeat(np.arange(len(Rf)), len(live)), np.tile(live, len(Rf))
        x, loc = np.empty((len(rows), 3)), np.empty((len(rows), 2))
        Rc = np.ascontiguousarray(Rf)
        pair_locations(Rc, coils, rows, cols, x, loc)
        d_theta, d_phi = field.synthesis(loc, 1, mode="DERIV1")
        out = np.zeros((len(Rf), 3, len(coils)))
        synthesis_columns(Rc, x, rows, cols, d_theta, d_phi, float(sign), out)
        return out.reshape(lead + (3, len(coils)))
    x = coils[live] @ Rf  # (K, n, 3)
    g = field.fields(x.reshape(-1, 3), 1, value=False)[1].reshape(x.shape)
    out = np.zeros((len(Rf), 3, len(coils)))
    out[:, :, live] = sign * (Rf @ np.swapaxes(cross(x, g), -1, -2))
    return out.reshape(lead + (3, len(coils)))


def pack_terms(terms, constant=0.0) -> Packed | None:
    """A torque model's zonal terms ``[(field, sign, coils, c), ...]`` — its energy is ``constant + Σ sign Σ_k c_k
    F(x_k)`` over the terms — as the :class:`~spherestep._fast.Packed` arrays ``(params, offsets, coils, C, poles
    (3, M), P, signs, constant)`` (``C (..., T, N)``: the terms' currents ``(..., N)`` broadcast and stacked) that
    :func:`spherestep._fast.terms.terms_evaluate` and the compiled descent and integrator take, or ``None`` when
    there are no terms, a term has no compiled kernel, or the terms do not share their poles and coils. The
    models' :meth:`~spherestep.statics.TorqueModel.packed_terms` call it."""
    if not terms:
        return None
    fields = [t[0] for t in terms]
    if len(terms) == 1 and fields[0].compiled is not None:  # one term: the field's own arrays
        field, sign, coils, c = terms[0]
        c = np.asarray(c, dtype=float)
        return Packed(field.compiled, _OFFSETS[len(field.compiled)], np.ascontiguousarray(coils, dtype=float),
                      c[..., None, :], field.poles_t, field.polarity_row, _SIGNS[sign], constant)
    poles, coils = fields[0].poles, np.ascontiguousarray(terms[0][2], dtype=float)
    if any(f.compiled is None or f.poles is not poles and not np.array_equal(f.poles, poles) for f in fields) \
            or any(t[2] is not terms[0][2] and not np.array_equal(t[2], coils) for t in terms[1:]):
        return None
    params, offsets, P = _joined(fields)
    currents = [np.asarray(t[3], dtype=float) for t in terms]
    lead = np.broadcast_shapes(*(c.shape[:-1] for c in currents))
    C = np.stack([np.broadcast_to(c, lead + c.shape[-1:]) for c in currents], axis=-2)
    return Packed(params, offsets, coils, C, fields[0].poles_t, P, np.array([float(t[1]) for t in terms]), constant)


_JOINED: dict = {}  # the fields' kernels' and polarities' ids -> (those arrays, the kernels joined, offsets, polarities)
JOINED_KEPT = 8  # models whose joined kernels are kept (the coupled iron model's are 7 MB)


def _joined(fields) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(params, offsets, P)``: the fields' compiled kernels concatenated, where each starts, and their polarity
    rows stacked — built once per set of fields (copying the iron model's kernels cost ~1 ms per call), kept for
    the last :data:`JOINED_KEPT`; the entry holds the arrays, so their ids stay theirs while it is kept."""
    held = tuple(a for f in fields for a in (f.compiled, f.polarity))
    key = tuple(map(id, held))
    hit = _JOINED.get(key)
    if hit is None or any(a is not b for a, b in zip(hit[0], held)):
        while len(_JOINED) >= JOINED_KEPT:
            _JOINED.pop(next(iter(_JOINED)))
        hit = _JOINED[key] = (held, np.concatenate([f.compiled for f in fields]),
                              np.concatenate([[0], np.cumsum([len(f.compiled) for f in fields])]),
                              np.stack([f.polarity for f in fields]))
    return hit[1:]
