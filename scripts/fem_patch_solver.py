"""The FEM of ``scripts/fem_patch.py`` (issue 28 §1): one orientation's mesh of the stator patch's iron cores and
the rotor magnets within reach, and its solves with NGSolve — linear iron (one factorisation, a solve per current
case) and the B–H curve (Newton on the co-energy). The formulation is ``fem_patch.py``'s module docstring; this
file holds only the solver, so the script's cases, storage and comparison read without NGSolve.
"""

from __future__ import annotations

import math
import time

import numpy as np

from spherestep.magnetics import _iron as iron

MU0 = 4e-7 * math.pi


class PatchSolver:
    """The mesh of one orientation (cores of ``coils``, magnets ``magnets`` at ``R``) and its solves; face mesh
    ``maxh``, ψ = 0 at ``outer`` (m), the far mesh 0.04 m × ``scale``."""

    def __init__(self, design, R, coils, magnets, maxh: float, outer: float, scale: float = 1.0):
        from netgen.occ import Cylinder, Dir, Glue, OCCGeometry, Pnt, Sphere
        from ngsolve import Mesh

        t0 = time.perf_counter()
        self.design, self.coils, self.magnets = design, tuple(coils), np.asarray(magnets)
        coil = design.coil
        g = self.g = iron.CoreGeometry.of(design, coil)
        face = self.face = design.radius + design.air_gap
        self.v = design.stator.centers[list(coils)]
        iron_parts, grooves = [], []
        for v in self.v:
            p0 = face * v

            def cyl(r, z0, h, v=v, p0=p0):
                return Cylinder(Pnt(*(p0 + z0 * v)), Dir(*v), r, h)

            pole_lo, pole_hi = cyl(g.r_p, 0.0, g.depth), cyl(g.r_p, g.depth, g.L - g.depth)
            wall = cyl(g.R, 0.0, g.depth) - cyl(g.r_w, 0.0, g.depth)
            back = cyl(g.R, g.depth, g.L - g.depth) - pole_hi
            groove = cyl(g.r_w, 0.0, g.depth) - pole_lo
            for p in (pole_lo, pole_hi, wall, back):
                p.mat("iron")
                p.maxh = 2.5 * maxh
            for f in pole_lo.faces + wall.faces:
                f.maxh = maxh
            groove.mat("winding")
            iron_parts += [pole_lo, pole_hi, wall, back]
            grooves.append(groove)
        self.w = np.asarray(R) @ design.rotor.centers[self.magnets].T  # (3, m)
        self.w = self.w.T
        self.p = design.polarity[self.magnets].astype(float)
        r_c = iron.magnet_face_radius(design) - 0.5 * design.magnet_length
        self.centres = r_c * self.w
        mags = []
        for j, (c, w) in enumerate(zip(self.centres, self.w)):
            base = c - 0.5 * design.magnet_length * w
            m = Cylinder(Pnt(*base), Dir(*w), 0.5 * design.magnet_diameter, design.magnet_length)
            m.mat(f"magnet{j}")
            m.maxh = 1.5 * maxh
            mags.append(m)
        centre = face * self.v.mean(axis=0)
        outer = Sphere(Pnt(*centre), outer)
        outer.faces.name = "outer"
        air = outer
        for s in iron_parts + grooves + mags:
            air = air - s
        air.mat("air")
        shape = Glue([air, *iron_parts, *grooves, *mags])
        self.mesh = Mesh(OCCGeometry(shape).GenerateMesh(maxh=0.04 * scale, grading=0.25))
        self._points()
        self.B_air = self._field(self._linear(1.0, np.zeros(len(coils)))[0])
        self._inverse = None  # the linear iron's factorisation, once made
        self.mesh_s = time.perf_counter() - t0

    def _points(self):
        """The magnets' face-charge points (a hair inside each magnet) and charges."""
        d = self.design
        pts, qs = [], []
        for c, w, p in zip(self.centres, self.w, self.p):
            x, q = iron.magnet_faces(c, p * w, d.magnet_diameter, d.magnet_length, d.remanence)
            x = x + np.where(q > 0, -1.0, 1.0)[:, None] * (p * w) * 1e-7
            pts.append(x)
            qs.append(q)
        self.pts, self.q = np.concatenate(pts), np.concatenate(qs)

    def _space(self):
        from ngsolve import H1
        return H1(self.mesh, order=2, dirichlet="outer")

    def _sources(self, currents):
        """``T0`` (A/m, the sum over the energised coils) and the magnets' ``M`` (A/m) as coefficient functions."""
        from ngsolve import CoefficientFunction, IfPos, sqrt, x, y, z

        g = self.g
        T0 = CoefficientFunction((0.0, 0.0, 0.0))
        for v, c in zip(self.v, currents):
            if c == 0:
                continue
            s = v[0] * x + v[1] * y + v[2] * z
            zl = s - self.face
            r = sqrt(IfPos(x * x + y * y + z * z - s * s, x * x + y * y + z * z - s * s, 0.0))
            prof = IfPos(g.r_p - r, 1.0, IfPos(g.r_w - r, (g.r_w - r) / (g.r_w - g.r_p), 0.0))
            t = c * g.NI / g.depth * prof * IfPos(zl, IfPos(g.depth - zl, 1.0, 0.0), 0.0)
            T0 = T0 + t * CoefficientFunction(tuple(float(a) for a in v))
        Ms = {f"magnet{j}": CoefficientFunction(tuple(float(a) for a in self.design.remanence / MU0 * p * w))
              for j, (w, p) in enumerate(zip(self.w, self.p))}
        return T0, Ms

    def _linear(self, mu_r: float, currents, inverse=None):
        from ngsolve import BilinearForm, GridFunction, LinearForm, TaskManager, dx, grad

        fes = self._space()
        psi, v = fes.TnT()
        if inverse is None:
            mu = self.mesh.MaterialCF({"iron": mu_r}, default=1.0)
            a = BilinearForm(fes, symmetric=True)
            a += mu * grad(psi) * grad(v) * dx
            with TaskManager():
                a.Assemble()
                inverse = a.mat.Inverse(fes.FreeDofs(), inverse="sparsecholesky")
        mu = self.mesh.MaterialCF({"iron": mu_r}, default=1.0)
        T0, Ms = self._sources(currents)
        f = LinearForm(fes)
        for name, M in Ms.items():
            f += M * grad(v) * dx(definedon=self.mesh.Materials(name))
        if any(currents):
            f += mu * T0 * grad(v) * dx(definedon=self.mesh.Materials("iron|winding"))
        gfu = GridFunction(fes)
        with TaskManager():
            f.Assemble()
            gfu.vec.data = inverse * f.vec
        return gfu, inverse

    def _field(self, gfu) -> np.ndarray:
        """``−μ0 ∇ψ`` (T) at the charge points (the ``T0`` and ``M`` terms cancel in the difference taken)."""
        from ngsolve import grad

        P = self.pts
        return -MU0 * np.asarray(grad(gfu)(self.mesh(P[:, 0], P[:, 1], P[:, 2]))).reshape(-1, 3)

    def torque(self, B) -> np.ndarray:
        return iron.charge_wrench(self.pts, self.q, B - self.B_air, (0.0, 0.0, 0.0))[1]

    def solve_linear(self, currents_list):
        """Torques (N·m) for each currents vector, linear iron: one factorisation, one solve each."""
        out = []
        for c in currents_list:
            t0 = time.perf_counter()
            gfu, self._inverse = self._linear(self.g.mu_r, c, self._inverse)
            out.append((self.torque(self._field(gfu)), 0, time.perf_counter() - t0))
        return out

    def solve_bh(self, currents, material):
        """Torque (N·m), Newton steps and time for the B–H curve (see the module docstring)."""
        from ngsolve import BilinearForm, BSpline, TaskManager, Variation, dx, grad, sqrt
        from ngsolve.solvers import NewtonMinimization

        t0 = time.perf_counter()
        onset = iron.saturation_onset(material, self.g.mu_r)
        bh = np.asarray(material.bh, dtype=float)
        H = np.concatenate([[0.0, onset], bh[bh[:, 0] > onset, 0], [1e8]])
        B = np.concatenate([[0.0, MU0 * self.g.mu_r * onset], bh[bh[:, 0] > onset, 1],
                            [bh[-1, 1] + MU0 * (1e8 - bh[-1, 0])]])
        curve = BSpline(2, [0.0] + list(H), list(B / MU0))  # B/μ0 (A/m) against H (A/m)
        wstar = curve.Integrate()
        gfu, self._inverse = self._linear(self.g.mu_r, currents, self._inverse)  # the start: the linear solve
        fes = gfu.space
        psi = fes.TrialFunction()
        T0, Ms = self._sources(currents)
        Hcf = T0 - grad(psi)
        a = BilinearForm(fes, symmetric=True)
        a += Variation(wstar(sqrt(1e-6 + Hcf * Hcf)) * dx("iron"))
        a += Variation(0.5 * Hcf * Hcf * dx("air|winding|" + "|".join(Ms)))
        for name, M in Ms.items():
            a += Variation(M * Hcf * dx(name))
        with TaskManager():
            status, steps = NewtonMinimization(a, gfu, freedofs=fes.FreeDofs(), maxit=40, maxerr=1e-3,
                                               inverse="sparsecholesky", linesearch=True, printing=False)
        if status != 0:
            raise RuntimeError(f"Newton did not converge in {steps} steps")
        return self.torque(self._field(gfu)), steps, time.perf_counter() - t0
