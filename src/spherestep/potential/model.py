"""``MotorPotential``: the phenomenological energy of eq. (4) for a whole motor, its torque and Hessian.

Model (Sec. III-B). Rotor pole ``j`` (body-frame centre ``u_j``, polarity ``p_j = ±1``) carries the field
``p_j f_r(u · R u_j)`` at orientation ``R``; stator coil ``k`` (fixed-frame centre ``v_k``, current ``c_k``) carries
``c_k f_s(u · v_k)``. The energy is eq. (4) summed over the motor,

    V(R, c) = ∫_{S²} | a_R(u) − b_c(u) |² du,   a_R = Σ_j p_j f_r(u · R u_j),   b_c = Σ_k c_k f_s(u · v_k),

so a coil with ``c_k = +1`` attracts poles with ``p_j = +1`` (the overlap of like signs lowers ``V``).

Harmonic form (the paper's point, Sec. III-B-3). Profiles are truncated at degree ``L`` (``bandlimit``). The
body-frame rotor field has coefficients ``Â(l, m) = Σ_j p_j λ_l(f_r) conj Y_l^m(u_j)``; since
``a_R(u) = a_I(Rᵀu)``, the corrected eq. (16) ``Y_l^n(Rᵀu) = Σ_m D^l_mn(R) Y_l^m(u)`` gives ``â_R^l = D^l(R) Â^l``.
With ``b̂(l, m) = Σ_k c_k λ_l(f_s) conj Y_l^m(v_k)`` and Plancherel (eq. (6)),

    V = ‖Â‖² + ‖b̂‖² − 2 Σ_l Re ⟨D^l(R) Â^l, b̂^l⟩,

and no integral over the sphere is left per orientation. ``‖Â‖²`` does not depend on ``R`` and ``‖b̂‖² = cᵀ S c``
with a fixed Gram matrix ``S``. The bilinear term is evaluated through the factorisation of ``D^l`` used by the
harmonics room (``P^l_mn(cos β) = Σ_k Π_km Π_kn cos(kβ − (m−n)π/2)``, ``Π = P^l(0)``, ZXZ angles ``α, β, γ``):

    ⟨D^l(R) Â^l, b̂^l⟩ = Σ_{k=−l..l} e^(ikβ) p_k q_k,
    p = Π [(−1)^m conj(b̂_m) e^(−imα)]_m,   q = Π [(−1)^n Â_n e^(−inγ)]_n,

two matrix–vector products of size ``2l+1`` per degree instead of forming the ``(2l+1)²`` matrix ``D^l``
(:meth:`MotorPotential.rotor_coefficients` does form it, with :func:`~spherestep.harmonics.s2_rotate`).

Pairwise form (Funk–Hecke). The same number is

    V = Σ_jj' p_j p_j' G_rr(u_j · u_j') + Σ_kk' c_k c_k' G_ss(v_k · v_k') − 2 Σ_jk p_j c_k G(R u_j · v_k),
    G(t) = Σ_{l≤L} λ_l(f_r) λ_l(f_s) (2l+1)/(4π) P_l(t),

with ``G`` tabulated (:class:`~spherestep.potential.ZonalKernel`): ``O(M N)`` work per orientation, no transforms.

Torque. Perturb ``R → exp(ω̂) R`` with ``ω`` in the fixed (spatial) frame. Then ``∂(R u_j · v_k)/∂ω = R u_j × v_k``
and the torque about the centre, in the fixed frame, is

    τ = −∂V/∂ω = 2 Σ_jk p_j c_k G'(R u_j · v_k) (R u_j × v_k);

it turns an attracted pole towards its coil (``G' > 0``). The body-frame torque is ``Rᵀ τ``. The Hessian of
``ω ↦ V(exp(ω̂) R)`` at ``ω = 0`` is

    H = −2 Σ_jk p_j c_k [G''(t) s sᵀ + G'(t) (½(v wᵀ + w vᵀ) − t I)],  w = R u_j, v = v_k, s = w × v, t = w · v.
"""

from __future__ import annotations

import math

import numpy as np

import dataclasses

from .. import checks, so3
from ..errors import bad_value
from .._fast import Packed
from ..rotor_field import RotorField, fast_evaluate, fast_torque_matrix, pack_terms, threads
from ..rotor_field import cross as _cross
from ..statics import TorqueModelBase
from ..harmonics import SO3Grid, half_pi_matrix, s2_rotate, so3_grid, so3_inverse, sph_harm_u
from .kernel import ZonalKernel
from .profiles import VonMisesFisher, ZonalProfile

CHUNK = 256  # orientations per block in the harmonic form (bounds memory to ~(L+1)(2L+1)·CHUNK complex)
PAIR_BLOCK = 1 << 18  # (orientation, coil, pole) triples per block in the pairwise form (~2 MB per array)


def coil_currents(design, coils) -> np.ndarray:
    """The current vector ``(N,)`` from a mapping ``coil index → current`` (e.g. ``design.states().coils(i)``):
    :meth:`~spherestep.motor.MotorDesign.coil_currents`, the one such helper."""
    return design.coil_currents(coils)


class MotorPotential(TorqueModelBase):
    """Eq. (4) for a motor design: energy ``V(R, c)``, torque, Hessian, and the energy over an SO(3) grid.

    ``design``: a :class:`~spherestep.motor.MotorDesign`. ``rotor_profile``, ``stator_profile``: zonal profiles
    (default :meth:`VonMisesFisher.from_half_width` of ``design.magnet_angle`` and ``design.coil_angle``: half
    maximum at the rim of the magnet's and the coil's face). ``bandlimit``: degree ``L`` at which the profiles
    are truncated (default: the larger :meth:`~ZonalProfile.bandwidth` of the two at ``tail``, 68 for the
    prototype at ``tail = 1e-10``). ``rtol``: accuracy of the tabulated ``G`` (see :class:`ZonalKernel`).

    Rotations ``R`` are ``(..., 3, 3)``, currents ``(..., N)`` with ``N = len(design.stator)`` (failed coils must
    carry zero); leading axes broadcast, and every method returns arrays with the broadcast leading shape.
    Units: those of ``amplitude_r · amplitude_s`` (arbitrary with the default amplitude 1; joules and newton
    metres once the profiles come from :func:`~spherestep.potential.fit_profile`). ``scale`` (J per model unit)
    multiplies both amplitudes by ``√scale``, so every energy, torque and Hessian is multiplied by ``scale``: the
    model in SI units for the dynamics. A :class:`~spherestep.statics.TorqueModel`.

    ``fast`` (default): ``energy``, ``torque``, ``energy_and_torque``, ``evaluate``, ``hessian`` and
    ``torque_matrix`` go through the rotor function ``F(x) = Σ_j p_j G(x·u_j)`` evaluated at the coils'
    body-frame directions (:mod:`spherestep.rotor_field`; ducc0 with ``nthreads`` threads for large batches);
    ``fast=False`` keeps the exact forms, which stay available by name (``energy_harmonic``,
    ``energy_pairwise``, ``evaluate_pairwise``, ``torque_matrix_pairwise``) as the reference.

    >>> from spherestep.motor import prototype
    >>> model = MotorPotential(prototype())
    >>> model.bandlimit
    68
    """

    def __init__(self, design, bandlimit=None, rotor_profile: ZonalProfile | None = None,
                 stator_profile: ZonalProfile | None = None, *, tail: float = 1e-10, rtol: float = 1e-12,
                 scale: float = 1.0, fast: bool = True, nthreads: int = 1):
        for label in ("rotor", "stator", "polarity"):
            if not hasattr(design, label):
                raise bad_value("design", "a MotorDesign", type(design).__name__)
        self.design = design
        self.rotor_profile = VonMisesFisher.from_half_width(design.magnet_angle) if rotor_profile is None \
            else rotor_profile
        self.stator_profile = VonMisesFisher.from_half_width(design.coil_angle) if stator_profile is None \
            else stator_profile
        for label, profile in (("rotor_profile", self.rotor_profile), ("stator_profile", self.stator_profile)):
            if not isinstance(profile, ZonalProfile):
                raise bad_value(label, "a ZonalProfile (e.g. VonMisesFisher)", profile)
        self.scale = checks.positive(scale, "scale")
        self.fast = bool(fast)
        self.nthreads = threads(nthreads)
        self._field = None
        if self.scale != 1.0:
            root = math.sqrt(self.scale)
            self.rotor_profile, self.stator_profile = (
                dataclasses.replace(profile, amplitude=profile.amplitude * root)
                for profile in (self.rotor_profile, self.stator_profile))
        if bandlimit is None:
            tail = checks.fraction(tail, "tail")
            bandlimit = max(self.rotor_profile.bandwidth(tail), self.stator_profile.bandwidth(tail))
        L = self.bandlimit = checks.count(bandlimit, "bandlimit", minimum=0)
        self.poles = np.asarray(design.rotor.centers, dtype=float)
        self.polarity = np.asarray(design.polarity, dtype=float)
        self.coils = np.ascontiguousarray(design.stator.centers, dtype=float)
        self.failed = tuple(design.failed_coils)
        self.coil_count = len(self.coils)
        self.lambda_rotor = self.rotor_profile.legendre_coefficients(L)
        self.lambda_stator = self.stator_profile.legendre_coefficients(L)
        degrees = np.arange(L + 1)
        weight = (2 * degrees + 1) / (4 * np.pi)
        self.kernel = ZonalKernel(self.lambda_rotor * self.lambda_stator * weight, rtol)
        self._rotor_series = self.lambda_rotor**2 * weight
        self._stator_series = self.lambda_stator**2 * weight

        # spherical Fourier coefficients (addition theorem): f̂(l, m) = λ_l conj Y_l^m(centre)
        conj_y_poles = _conj_harmonics(self.poles, L)  # (M, L+1, 2L+1)
        conj_y_coils = _conj_harmonics(self.coils, L)  # (N, L+1, 2L+1)
        self.rotor_body = np.einsum("j,jlm->lm", self.polarity, conj_y_poles) * self.lambda_rotor[:, None]
        self.stator_fields = conj_y_coils * self.lambda_stator[:, None]  # (N, L+1, 2L+1)
        self.rotor_norm2 = float(np.sum(np.abs(self.rotor_body) ** 2))
        flat = self.stator_fields.reshape(len(self.coils), -1)
        self.stator_gram = np.real(flat @ flat.conj().T)
        self._stator_re = np.ascontiguousarray(flat.real.T)  # ((L+1)(2L+1), N)
        self._stator_im = np.ascontiguousarray(flat.imag.T)
        # the same constants in the pairwise form, from the Legendre series (exact sums, no tables)
        from numpy.polynomial.legendre import legval

        self._rotor_norm2_pairwise = float(self.polarity @ legval(np.clip(self.poles @ self.poles.T, -1, 1),
                                                                 self._rotor_series) @ self.polarity)
        self._stator_gram_pairwise = legval(np.clip(self.coils @ self.coils.T, -1, 1), self._stator_series)
        self._pi_split = []
        for l in range(L + 1):  # rows k = 0..l of Π = P^l(0), columns split by the parity of m
            upper = half_pi_matrix(l)[l:]
            even = np.nonzero(np.arange(-l, l + 1) % 2 == 0)[0]
            odd = np.nonzero(np.arange(-l, l + 1) % 2 == 1)[0]
            self._pi_split.append((even, odd, np.ascontiguousarray(upper[:, even]),
                                   np.ascontiguousarray(upper[:, odd])))
        self._sign = (-1.0) ** np.arange(-L, L + 1)

    def __repr__(self) -> str:
        return (f"MotorPotential({getattr(self.design, 'name', 'design')!r}, bandlimit={self.bandlimit}, "
                f"rotor_profile={self.rotor_profile!r}, stator_profile={self.stator_profile!r})")

    # --- inputs ---------------------------------------------------------------------------------------
    def _inputs(self, R, currents) -> tuple[np.ndarray, np.ndarray]:
        R = so3.as_rotations(R)
        c = checks.currents(currents, len(self.coils), self.failed)
        if R.ndim == 2 and c.ndim == 1:
            return R, c
        try:
            np.broadcast_shapes(R.shape[:-2], c.shape[:-1])
        except ValueError:
            raise bad_value("currents", f"leading axes that broadcast against R's {R.shape[:-2]}",
                            f"shape {c.shape}") from None
        return R, c

    def _constant(self, c: np.ndarray, pairwise: bool) -> np.ndarray:
        """``‖Â‖² + cᵀ S c``: the part of ``V`` that does not depend on ``R``."""
        norm2, gram = (self._rotor_norm2_pairwise, self._stator_gram_pairwise) if pairwise else \
            (self.rotor_norm2, self.stator_gram)
        if c.ndim == 1:
            return norm2 + gram.dot(c).dot(c)
        return norm2 + (c @ gram * c).sum(-1)

    # --- fast path: the rotor function at the coils ------------------------------------------------------
    @property
    def rotor_field(self) -> RotorField:
        """``F(x) = Σ_j p_j G(x · u_j)`` (body frame), so ``V = ‖Â‖² + cᵀSc − 2 Σ_k c_k F(Rᵀ v_k)``; built on first
        use (exact: ``F`` has degree ``L``)."""
        if self._field is None:
            self._field = RotorField(self.poles, self.polarity, self._kernel_derivatives, self.bandlimit,
                                     nthreads=self.nthreads, compiled=("quintic", self.kernel.table))
        return self._field

    def _kernel_derivatives(self, t: np.ndarray, orders: tuple[int, ...]) -> tuple[np.ndarray, ...]:
        """``G^(n)(t)`` for ``n`` in ``orders``, from one look-up of the kernel's table."""
        if orders == (0,):
            return (self.kernel.value(t),)
        if orders == (1,):
            return (self.kernel.derivative(t),)
        values = self.kernel.evaluate(t, max(orders))
        return tuple(values[n] for n in orders)

    def _fast(self, R: np.ndarray, c: np.ndarray, order: int, value: bool = True) -> tuple[np.ndarray, ...]:
        constant = self._constant(c, pairwise=True) if value else None
        return fast_evaluate(self.rotor_field, -2.0, self.coils, R, c, order, constant, value)

    def zonal_terms(self, currents) -> list | None:
        """``[(rotor_field, −2, coils, c)]``: the torque as a zonal sum (:func:`spherestep.rotor_field.pack_terms`;
        the compiled integrator's input), ``None`` with ``fast=False``."""
        c = checks.currents(currents, len(self.coils), self.failed)
        return [(self.rotor_field, -2.0, self.coils, c)] if self.fast else None

    def zonal_constant(self, currents) -> np.ndarray:
        """``‖Â‖² + cᵀSc``: the energy's part besides its zonal terms (:func:`spherestep.statics.equilibrium`)."""
        return self._constant(checks.currents(currents, len(self.coils), self.failed), pairwise=True)

    has_bias = False  # no current, no stator field: V = ‖Â‖² for every R

    @property
    def affine_in_currents(self) -> bool:
        """The packed term's coefficients are ``−2 c_k`` (its constant ``‖Â‖² + cᵀSc`` carries no torque): affine
        when there are packed terms (``fast``)."""
        return self.fast

    def packed_terms(self, currents) -> Packed | None:
        """The energy ``‖Â‖² + cᵀSc − 2 Σ_k c_k F(x_k)`` as one compiled zonal term and its constant
        (:func:`spherestep.rotor_field.pack_terms`), ``None`` with ``fast=False``."""
        if not self.fast:
            return None
        c = checks.currents(currents, len(self.coils), self.failed)
        return pack_terms([(self.rotor_field, -2.0, self.coils, c)], self._constant(c, pairwise=True))

    def energy(self, R, currents) -> np.ndarray:
        """``V(R, c)`` (eq. (4)): the fast path, or :meth:`energy_harmonic` with ``fast=False``."""
        if self.fast:
            R, c = self._inputs(R, currents)
            return self._fast(R, c, 0)[0]
        return self.energy_harmonic(R, currents)

    # --- harmonic form ---------------------------------------------------------------------------------
    def energy_harmonic(self, R, currents) -> np.ndarray:
        """Eq. (4) by Plancherel: ``V = ‖Â‖² + cᵀSc − 2 Σ_l Re⟨D^l(R) Â^l, b̂^l⟩`` (see the module docstring).

        ``R`` ``(..., 3, 3)``, ``currents`` ``(..., N)``; returns the broadcast leading shape. Cost ``O(L³)`` per
        orientation (two products of size ``2l+1`` per degree), vectorised over the batch in blocks of 256.
        """
        R, c = self._inputs(R, currents)
        lead = np.broadcast_shapes(R.shape[:-2], c.shape[:-1])
        R_flat = np.broadcast_to(R, lead + (3, 3)).reshape(-1, 3, 3)
        c_flat = np.broadcast_to(c, lead + (c.shape[-1],)).reshape(-1, c.shape[-1])
        cross = np.empty(len(R_flat))
        for start in range(0, len(R_flat), CHUNK):
            block = slice(start, start + CHUNK)
            cross[block] = self._cross_harmonic(R_flat[block], c_flat[block])
        return (self._constant(c, pairwise=False) - 2.0 * cross.reshape(lead))

    def _cross_harmonic(self, R: np.ndarray, c: np.ndarray) -> np.ndarray:
        """``Σ_l Re⟨D^l(R) Â^l, b̂^l⟩`` for ``K`` rotations and ``K`` current vectors (transposed layout, ``(·, K)``).

        Eq. (12) at ``x = 0`` gives ``Π_−k,m = (−1)^(l+m) Π_km``, so with the rows ``k ≥ 0`` split by the parity of
        ``m``, ``E = Π_k,even x_even`` and ``O = Π_k,odd x_odd``: ``p_k = E + O`` and ``p_−k = (−1)^l (E − O)``. Hence
        ``Σ_k e^(ikβ) p_k q_k = Σ_{k≥0} e^(ikβ) (E+O)(E'+O') + Σ_{k≥1} e^(−ikβ) (E−O)(E'−O')`` (the signs cancel),
        with half-size products.
        """
        L = self.bandlimit
        K = len(R)
        angles = so3.to_euler_zxz(R)
        orders = np.arange(-L, L + 1)
        e_alpha = np.exp(-1j * np.multiply.outer(orders, angles[:, 0]))  # (2L+1, K)
        e_gamma = np.exp(-1j * np.multiply.outer(orders, angles[:, 2]))
        e_beta = np.exp(1j * np.multiply.outer(np.arange(L + 1), angles[:, 1]))  # (L+1, K), k = 0..L
        cT = np.ascontiguousarray(c.T)
        b_conj = (self._stator_re @ cT - 1j * (self._stator_im @ cT)).reshape(L + 1, 2 * L + 1, K)
        x_all = self._sign[:, None] * e_alpha  # (−1)^m e^(−imα)
        y_all = (self._sign[None, :] * self.rotor_body)[:, :, None] * e_gamma[None]  # (L+1, 2L+1, K)
        total = np.zeros(K, dtype=complex)
        for l in range(L + 1):
            even, odd, pi_even, pi_odd = self._pi_split[l]
            x = x_all[L - l: L + l + 1] * b_conj[l, L - l: L + l + 1]
            y = y_all[l, L - l: L + l + 1]
            xe, xo = _real_times_complex(pi_even, x[even]), _real_times_complex(pi_odd, x[odd])
            ye, yo = _real_times_complex(pi_even, y[even]), _real_times_complex(pi_odd, y[odd])
            up = np.einsum("kb,kb,kb->b", e_beta[: l + 1], xe + xo, ye + yo)
            down = np.einsum("kb,kb,kb->b", np.conj(e_beta[1: l + 1]), (xe - xo)[1:], (ye - yo)[1:])
            total += up + down
        return total.real

    def rotor_coefficients(self, R) -> np.ndarray:
        """Coefficients ``â_R^l = D^l(R) Â^l`` of the rotated rotor field (corrected eq. (16), via ``wigner_D``
        in :func:`~spherestep.harmonics.s2_rotate`), ``(..., L+1, 2L+1)``; ``f̂[l, m+L]`` multiplies ``Y_l^m``."""
        R = so3.as_rotations(R)
        return s2_rotate(self.rotor_body, R)

    def stator_coefficients(self, currents) -> np.ndarray:
        """Coefficients ``b̂ = Σ_k c_k λ_l(f_s) conj Y_l^m(v_k)`` of the stator field, ``(..., L+1, 2L+1)``."""
        c = checks.currents(currents, len(self.coils), self.failed)
        return np.einsum("...k,klm->...lm", c, self.stator_fields)

    # --- pairwise form -----------------------------------------------------------------------------------
    def energy_pairwise(self, R, currents) -> np.ndarray:
        """``V = Σ p p' G_rr + cᵀ S c − 2 Σ_jk p_j c_k G(R u_j · v_k)``: the same energy as :meth:`energy`,
        ``O(M N)`` per orientation (only energised coils count)."""
        R, c = self._inputs(R, currents)
        return self._pairwise(R, c, 0)[0]

    def torque(self, R, currents) -> np.ndarray:
        """``τ = −∂V/∂ω = 2 Σ_jk p_j c_k G'(R u_j · v_k) (R u_j × v_k)``, fixed frame, for ``R → exp(ω̂) R``;
        shape ``(..., 3)``. The body-frame torque is ``Rᵀ τ``. Fast path (without the energy) unless ``fast=False``."""
        R, c = self._inputs(R, currents)
        return self._fast(R, c, 1, value=False)[1] if self.fast else self._pairwise(R, c, 1)[1]

    def energy_and_torque(self, R, currents) -> tuple[np.ndarray, np.ndarray]:
        """``(V, τ)`` in one pass (the call for a simulation's inner loop)."""
        return self.evaluate(R, currents, 1)

    def evaluate(self, R, currents, order: int) -> tuple[np.ndarray, ...]:
        """``(V,)``, ``(V, τ)`` or ``(V, τ, H)``: the fast path, or :meth:`evaluate_pairwise` with ``fast=False``."""
        R, c = self._inputs(R, currents)
        return self._fast(R, c, order) if self.fast else self._pairwise(R, c, order)

    def evaluate_pairwise(self, R, currents, order: int) -> tuple[np.ndarray, ...]:
        """``(V,)``, ``(V, τ)`` or ``(V, τ, H)`` from one pass over the pairs (the exact pairwise form)."""
        R, c = self._inputs(R, currents)
        return self._pairwise(R, c, order)

    def torque_matrix(self, R, currents=None) -> np.ndarray:
        """``K(R) = ∂τ/∂c``, ``(..., 3, N)``: column ``k`` is ``−2 R (x_k × ∇F(x_k))``, ``x_k = Rᵀ v_k`` (fast path;
        :meth:`torque_matrix_pairwise` with ``fast=False``). Zero columns for failed coils."""
        if not self.fast:
            return self.torque_matrix_pairwise(R)
        R = so3.as_rotations(R)
        return fast_torque_matrix(self.rotor_field, -2.0, self.coils, self.failed, R)

    def torque_matrix_pairwise(self, R, currents=None) -> np.ndarray:
        """``K(R) = ∂τ/∂c``, ``(..., 3, N)``: column ``k`` is ``2 Σ_j p_j G'(R u_j · v_k) (R u_j × v_k)``; the torque
        is linear in the currents, so ``currents`` does not matter. Zero columns for failed coils."""
        R = so3.as_rotations(R)
        W = np.swapaxes(R @ self.poles.T, -1, -2)  # (..., M, 3) poles in the fixed frame
        slope = self.kernel.evaluate(W @ self.coils.T, 1)[1] * self.polarity[:, None]  # (..., M, N) p_j G'
        Q = np.swapaxes(slope, -1, -2) @ W  # (..., N, 3): Σ_j p_j G'(t_jk) w_j
        K = 2.0 * np.swapaxes(_cross(Q, self.coils), -1, -2)
        K[..., list(self.failed)] = 0.0
        return K

    def torque_reference(self, currents) -> np.ndarray:
        """``τ_ref = 2 max|G'| Σ_k |c_k|``: the largest torque one pole per coil could feel."""
        return 2.0 * self.kernel.maxima[1] * np.sum(np.abs(np.asarray(currents, dtype=float)), axis=-1)

    def hessian(self, R, currents) -> np.ndarray:
        """Hessian ``∂²V/∂ω∂ω`` of ``ω ↦ V(exp(ω̂) R)`` at ``ω = 0`` (fixed frame), ``(..., 3, 3)``, symmetric.

        ``H = −2 Σ_jk p_j c_k [G'' s sᵀ + G' (½(v wᵀ + w vᵀ) − t I)]``, ``w = R u_j``, ``s = w × v_k``, ``t = w · v_k``.
        At an equilibrium its eigenvalues are the rotational stiffnesses. Fast path unless ``fast=False``.
        """
        return self.evaluate(R, currents, 2)[2]

    def _pairwise(self, R: np.ndarray, c: np.ndarray, order: int) -> tuple[np.ndarray, ...]:
        """Energy (and torque for ``order ≥ 1``, Hessian for ``order = 2``) of validated inputs, in blocks of at
        most ``PAIR_BLOCK`` (pole, coil, orientation) triples."""
        lead = np.broadcast_shapes(R.shape[:-2], c.shape[:-1])
        live = int(np.count_nonzero(np.any(c != 0, axis=tuple(range(c.ndim - 1)))))
        if math.prod(R.shape[:-2]) * live * len(self.poles) <= PAIR_BLOCK:
            return self._pairwise_block(R, c, order)
        R_flat = np.broadcast_to(R, lead + (3, 3)).reshape(-1, 3, 3)
        c_flat = np.broadcast_to(c, lead + c.shape[-1:]).reshape(-1, c.shape[-1])
        rows = max(1, PAIR_BLOCK // (live * len(self.poles)))
        parts = [self._pairwise_block(R_flat[i:i + rows], c_flat[i:i + rows], order)
                 for i in range(0, len(R_flat), rows)]
        return tuple(np.concatenate([part[q] for part in parts]).reshape(lead + parts[0][q].shape[1:])
                     for q in range(len(parts[0])))

    def _pairwise_block(self, R: np.ndarray, c: np.ndarray, order: int) -> tuple[np.ndarray, ...]:
        lead = np.broadcast_shapes(R.shape[:-2], c.shape[:-1])
        live = np.flatnonzero(np.any(c != 0, axis=tuple(range(c.ndim - 1))))
        energy = self._constant(c, pairwise=True)
        if len(live) == 0:
            out = [_full(energy, lead)]
            if order >= 1:
                out.append(np.zeros(lead + (3,)))
            if order >= 2:
                out.append(np.zeros(lead + (3, 3)))
            return tuple(out)
        v = self.coils[live]  # (n, 3)
        c_live = c[..., live]  # (..c, n)
        W = R @ self.poles.T  # (..R, 3, M): poles in the fixed frame, as columns
        T = v @ W  # (..R, n, M): t_kj = R u_j · v_k
        p = self.polarity
        values = self.kernel.evaluate(T, order) if order else (self.kernel.value(T),)
        energy = energy - 2.0 * np.sum((values[0] @ p) * c_live, axis=-1)
        out = [_full(energy, lead)]
        if order >= 1:
            Q = (values[1] * p) @ np.swapaxes(W, -1, -2)  # (..R, n, 3): Σ_j p_j G'(t_kj) w_j
            out.append(_full(2.0 * np.sum(c_live[..., None] * _cross(Q, v), axis=-2), lead + (3,)))
        if order >= 2:
            w = np.swapaxes(W, -1, -2)[..., None, :, :]  # (..R, 1, M, 3)
            s = _cross(w, v[:, None, :])  # (..R, n, M, 3)
            curvature = np.einsum("...kj,...kja,...kjb->...kab", values[2] * p, s, s)
            slope_t = np.sum(values[1] * p * T, axis=-1)
            outer = v[:, :, None] * Q[..., None, :]  # v_k Q_kᵀ
            per_coil = curvature + 0.5 * (outer + np.swapaxes(outer, -1, -2)) - slope_t[..., None, None] * np.eye(3)
            out.append(_full(-2.0 * np.sum(c_live[..., None, None] * per_coil, axis=-3), lead + (3, 3)))
        return tuple(out)

    # --- brute force ---------------------------------------------------------------------------------------
    def energy_quadrature(self, R, currents, n=None, band_limited: bool = False) -> np.ndarray:
        """Eq. (4) by brute-force quadrature over the sphere, for validation.

        Gauss–Legendre in ``cos θ`` (``n`` nodes) × the trapezoid rule in ``φ`` (``2n`` points). With
        ``band_limited=False`` the profiles themselves are integrated (default ``n = 2L + 2``: the integrand's
        coefficients beyond degree ``4L+3`` are far below rounding for the profiles the default ``L`` resolves);
        with ``band_limited=True`` their degree-``L`` Legendre series are (default ``n = L + 1``, exact: the
        integrand has degree ``2L``). Cost ``O(n² (M + N))`` per orientation; one orientation at a time.
        """
        R, c = self._inputs(R, currents)
        if n is None:
            n = self.bandlimit + 1 if band_limited else 2 * self.bandlimit + 2
        n = checks.count(n, "n", minimum=1)
        lead = np.broadcast_shapes(R.shape[:-2], c.shape[:-1])
        R_flat = np.broadcast_to(R, lead + (3, 3)).reshape(-1, 3, 3)
        c_flat = np.broadcast_to(c, lead + (c.shape[-1],)).reshape(-1, c.shape[-1])
        x, w = np.polynomial.legendre.leggauss(n)
        phi = np.pi * np.arange(2 * n) / n
        sin_theta = np.sqrt(1.0 - x * x)
        points = np.stack([np.multiply.outer(sin_theta, np.cos(phi)), np.multiply.outer(sin_theta, np.sin(phi)),
                           np.repeat(x[:, None], 2 * n, axis=1)], axis=-1).reshape(-1, 3)
        weights = np.repeat(w * (np.pi / n), 2 * n)
        if band_limited:
            from numpy.polynomial.legendre import legval

            weight = (2 * np.arange(self.bandlimit + 1) + 1) / (4 * np.pi)
            rotor = lambda t: legval(t, self.lambda_rotor * weight)  # noqa: E731
            stator = lambda t: legval(t, self.lambda_stator * weight)  # noqa: E731
        else:
            rotor, stator = self.rotor_profile, self.stator_profile
        stator_at = stator(np.clip(points @ self.coils.T, -1.0, 1.0))  # (P, N)
        out = np.empty(len(R_flat))
        for i, (Ri, ci) in enumerate(zip(R_flat, c_flat)):
            a = rotor(np.clip(points @ (Ri @ self.poles.T), -1.0, 1.0)) @ self.polarity
            out[i] = weights @ (a - stator_at @ ci) ** 2
        return out.reshape(lead)

    # --- the energy on an SO(3) grid ---------------------------------------------------------------------------
    def energy_coefficients(self, currents, lmax=None) -> np.ndarray:
        """SO(3) Fourier coefficients (eqs. (13)–(14)) of ``R ↦ V(R, c)``, padded to ``lmax ≥ L``,
        ``(..., lmax+1, 2lmax+1, 2lmax+1)``.

        From ``V = ‖Â‖² + ‖b̂‖² − 2 Σ conj(b̂_m) D^l_mn Â_n`` and ``D^l_mn = (−1)^(m−n) U^l_mn``, matching
        eq. (13) ``V = Σ_l (2l+1) Σ_mn V̂^l_nm U^l_mn`` gives ``V̂^l_nm = −2 (−1)^(m+n) Â_n conj(b̂_m)/(2l+1)``,
        plus the constant in ``V̂^0``.
        """
        L = self.bandlimit
        lmax = L if lmax is None else checks.count(lmax, "lmax", minimum=0)
        if lmax < L:
            raise bad_value("lmax", f"at least the model's band limit {L} (the energy has degree L on SO(3))", lmax)
        c = checks.currents(currents, len(self.coils), self.failed)
        b = np.einsum("...k,klm->...lm", c, self.stator_fields)  # (..., L+1, 2L+1)
        size = 2 * lmax + 1
        out = np.zeros(c.shape[:-1] + (lmax + 1, size, size), dtype=complex)
        sign = self._sign
        inv = -2.0 / (2 * np.arange(L + 1) + 1)
        block = (inv[:, None, None] * (sign * self.rotor_body)[:, :, None]
                 * (sign * np.conj(b))[..., :, None, :])  # (..., l, n, m)
        pad = lmax - L
        out[..., : L + 1, pad: pad + 2 * L + 1, pad: pad + 2 * L + 1] = block
        out[..., 0, lmax, lmax] += self._constant(c, pairwise=False)
        return out

    def energy_grid(self, currents, lmax=None) -> tuple[SO3Grid, np.ndarray]:
        """The energy at every point of :func:`~spherestep.harmonics.so3_grid` ``(lmax)`` (default ``L``) in ZXZ
        Euler angles, by the SO(3) inverse transform (FFTs over ``α`` and ``γ``, SOFT-style) of
        :meth:`energy_coefficients`. Returns ``(grid, V)`` with ``V`` ``(..., 2lmax+1, lmax+1, 2lmax+1)`` over
        ``(α, β, γ)``; ``grid.rotations()`` are the matching rotations."""
        fhat = self.energy_coefficients(currents, lmax)
        grid = so3_grid(fhat.shape[-3] - 1)
        return grid, so3_inverse(fhat).real


def _conj_harmonics(points: np.ndarray, L: int) -> np.ndarray:
    """``conj Y_l^m(points)`` padded as ``(P, L+1, 2L+1)`` (zero where ``|m| > l``)."""
    out = np.zeros((len(points), L + 1, 2 * L + 1), dtype=complex)
    for l in range(L + 1):
        orders = np.arange(-l, l + 1)
        out[:, l, L - l: L + l + 1] = np.conj(sph_harm_u(l, orders[None, :], points[:, None, :]))
    return out


def _full(a: np.ndarray, shape: tuple) -> np.ndarray:
    """``a`` as an array of exactly ``shape`` (broadcast copy only when needed)."""
    a = np.asarray(a)
    return a if a.shape == shape else np.broadcast_to(a, shape).copy()


def _real_times_complex(real: np.ndarray, cplx: np.ndarray) -> np.ndarray:
    """``real @ cplx`` for a real ``(a, b)`` matrix and a complex ``(b, K)`` array, with real BLAS."""
    pairs = np.ascontiguousarray(cplx).view(float)  # (b, 2K), real and imaginary parts interleaved
    return np.ascontiguousarray(real @ pairs).view(complex)
