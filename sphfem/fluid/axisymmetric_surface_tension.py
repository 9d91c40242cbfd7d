"""Continuum surface force (CSF) for the axisymmetric fluid of :mod:`sphfem.fluid.axisymmetric`.

The planar CSF of :mod:`sphfem.fluid.surface_tension_csf` (Brackbill, Kothe & Zemach 1992;
SPH form after Morris 2000) run in the meridian (r, z) half-plane, with planar areas
A_i = M_i / (2 pi r_i rho_i) as particle volumes and the axis mirrors (-r, z) of the fluid
as neighbours, plus the hoop part of the curvature.  With n the unit normal pointing into
the liquid, the mean curvature of an axisymmetric surface is (e.g. Batchelor 1967, app. 2,
divergence in cylindrical coordinates)

    kappa = -div n = -(d_r n_r + d_z n_z) - n_r / r = kappa_m + kappa_h,              (1)

kappa_m the curvature of the meridian curve (the planar -div n of the (r, z) plane) and
kappa_h = -n_r / r the curvature of the parallel circle (hoop).  A sphere of radius R0 has
kappa_m = kappa_h = 1 / R0, a cylinder along z kappa_m = 0 and kappa_h = 1 / R0.

Passes (each a numba kernel; the planar ones are those of the planar CSF):

1. colour gradient g_i = sum_j A_j grad_i W_ij and normal weight omega_i
   (:func:`~sphfem.fluid.surface_tension_csf.csf_normals`), over fluid, wall and mirror
   neighbours; then copied to the mirrors with the parity of a vector (g_r odd across the
   axis, g_z odd across a wall plane; :func:`mirror_normals`);
2. meridian curvature kappa_m (:func:`~sphfem.fluid.surface_tension_csf.csf_curvature`,
   dim = 2: the tangential-moment-corrected -div n of the plane);
3. hoop curvature (:func:`hoop_curvature`), added to kappa.  Near the axis -n_r / r is a
   ratio of two vanishing quantities: n_r is odd in r and carries the kernel-smoothing and
   lattice error of the colour gradient, which the division by r_i ~ dx/2 amplifies.  The
   even continuation gives the limit (L'Hopital) -n_r / r -> -d_r n_r, and on the axis a
   smooth surface is normal to it, so there -d_r n_r = kappa_m (the two principal curvatures
   are equal at an umbilic pole).  Hence

       kappa_h,i = s_i (-n_r,i / r_i) + (1 - s_i) kappa_m,i,
       s_i = smoothstep((r_i - a R) / (b R - a R)),

   with the support radius R, (a, b) = :data:`AXIS_BAND`: the pointwise ratio away from the
   axis, the meridian curvature at the axis.  kappa_h - kappa_m is even and vanishes at
   r = 0, so the blend errs by O(r^2) there, i.e. O(R^2) (zero on a sphere);
4. band curvature (Shepard extension) and force a_i = 2 sigma kbar_i g_i / rho_i
   (:func:`~sphfem.fluid.surface_tension_csf.csf_force`), with kappa copied to the mirrors.

Why the planar force needs nothing else: the axisymmetric pressure acceleration is
-sum_j mt_j (p_i / rho_i^2 + p_j / rho_j^2) grad_i W_ij with planar masses mt = rho A, so a
uniform pressure P acts on every particle with -2 P g_i / rho_i, as in the planar case; the
static balance per particle is again P = sigma kbar (Laplace's jump 2 sigma / R0 on a
sphere).  The pressure gradient has no hoop term; the hoop part lives in the curvature.

Support: one scalar radius R for all CSF sums (the planar passes take a scalar).  The
fluid's hook passes its widest fluid support, which is R itself unless ``adaptive_h``; with
adaptive h and the median support instead, a D/dx = 16 impact (10 m/s, sigma = 0.072 N/m)
blew up at the axis at 1.46 t_c, with the widest it ran to 3 t_c.

Time step (capillary waves, Brackbill et al. 1992): dt <= 0.25 sqrt(rho h^3 / (2 pi sigma))
(:func:`capillary_dt`; not among the fluid's own limits: callers take the minimum).

Checks (tests/test_axisymmetric_surface_tension.py): prescribed sphere (arcs of
:func:`half_disc_arcs`): kappa = 2 / rho1 within 1 % per particle (rho1 = R0 - dx/2, the
outer arc), the planar part alone 1 / rho1; cylinder: kappa_m = 0, kappa_h = 1 / r to 1e-3;
slab: 0.  The staircase of :func:`~sphfem.axisymmetric.half_disc_lattice` gives meridian
curvatures of +-3 / R0 per particle at R0/dx = 20 (the planar CSF's response to a lattice
staircase), so the prescribed-field checks use arcs; a droplet started on the lattice relaxes
(Laplace pressure within 2.3 % at R0/dx = 20).  Droplet at rest: inner pressure 2 sigma /
rho1 within 0.1 %, i.e. 2 sigma / R0 with the first-order layer offset (5.2 / 2.5 / 1.2 %
at R0/dx = 10 / 20 / 40); spurious currents < 5e-4 sigma / mu.  Rayleigh's l = 2 period
within 0.6 % at R0/dx = 10 and 20; the remaining error is the weak compressibility of the
run (c0 = 3.8 m/s: doubling c0 takes it from 0.59 % to 0.16 % at R0/dx = 20), not the
spatial discretisation.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from sphfem import kernels
from sphfem.axisymmetric import MIRROR_FLUID, MIRROR_WALL
from sphfem.fluid.surface_tension_csf import (
    DELTA_FACTOR,
    NORMAL_HI,
    NORMAL_LO,
    SHEPARD_MIN,
    TANGENT_MIN,
    csf_curvature,
    csf_force,
    csf_normals,
    csf_state,
)
from sphfem.particles import FLUID, WALL

#: the hoop curvature blends from kappa_m (r < a R) to -n_r / r (r > b R), R the support
AXIS_BAND = (0.5, 1.5)


@njit(cache=True)
def mirror_normals(n, src, mtype, g, omega):
    """Copy the colour gradient and normal weight of the sources onto the mirror rows
    n + q (in order: a source may be an earlier mirror).  ``mtype`` 0: image across the axis
    (g_r negated); 1: image across a wall plane z = const (g_z negated)."""
    for q in range(src.shape[0]):
        s = src[q]
        k = n + q
        omega[k] = omega[s]
        if mtype[q] == 0:
            g[k, 0] = -g[s, 0]
            g[k, 1] = g[s, 1]
        else:
            g[k, 0] = g[s, 0]
            g[k, 1] = -g[s, 1]


@njit(cache=True)
def mirror_scalar(n, src, a):
    """a[n + q] = a[src[q]] (an even scalar, in order)."""
    for q in range(src.shape[0]):
        a[n + q] = a[src[q]]


@njit(cache=True, parallel=True)
def hoop_curvature(r, g, omega, kappa_m, r_in, r_out, kappa_h):
    """Hoop curvature ``kappa_h`` of the rows with a valid normal (omega > 0; 0 elsewhere):
    -n_r / r with n = g / |g| for r >= ``r_out``, the meridian curvature ``kappa_m`` (the
    axis limit) for r <= ``r_in``, smoothstep blend between (module docstring, pass 3)."""
    for i in prange(r.shape[0]):
        kappa_h[i] = 0.0
        if omega[i] == 0.0:
            continue
        a = (r[i] - r_in) / (r_out - r_in)
        s = 1.0
        if a <= 0.0:
            s = 0.0
        elif a < 1.0:
            s = a * a * (3.0 - 2.0 * a)
        k = 0.0
        if s > 0.0:
            gn = math.sqrt(g[i, 0] * g[i, 0] + g[i, 1] * g[i, 1])
            k = -g[i, 0] / (gn * r[i])
        kappa_h[i] = s * k + (1.0 - s) * kappa_m[i]


def colour_kinds(kind) -> np.ndarray:
    """Kinds as the planar CSF passes read them: fluid mirrors count as FLUID, wall mirrors
    as WALL (their rows have no neighbours in the axisymmetric list; they are filled by
    :func:`mirror_normals` / :func:`mirror_scalar`)."""
    k = np.asarray(kind, np.int8).copy()
    k[k == MIRROR_FLUID] = FLUID
    k[k == MIRROR_WALL] = WALL
    return k


def half_disc_arcs(radius: float, dx: float, center_z: float = 0.0):
    """Meridian half-disc of a sphere of ``radius`` filled with concentric half-circle arcs
    (a smooth surface rather than the staircase of
    :func:`~sphfem.axisymmetric.half_disc_lattice`; the meridian section of the 3D
    :func:`~sphfem.fluid.setup.droplet_packing`): arc k at rho_k = (k + 1/2) dx' (dx' =
    radius / round(radius / dx), the outer arc at radius - dx'/2) with N_k = round(pi rho_k /
    dx') points at the polar angles (j + 1/2) pi / N_k, none on the axis.

    Returns ``(x, area)``: positions (r, z) and meridian areas pi rho_k dx' / N_k (the
    half-annulus of arc k shared evenly; they sum to pi radius^2 / 2)."""
    nr = max(1, int(round(radius / dx)))
    dx = radius / nr
    xs, areas = [], []
    for k in range(nr):
        rk = (k + 0.5) * dx
        m = max(1, int(round(math.pi * rk / dx)))
        th = (np.arange(m) + 0.5) * math.pi / m
        xs.append(np.column_stack([rk * np.sin(th), center_z + rk * np.cos(th)]))
        areas.append(np.full(m, math.pi * rk * dx / m))
    return np.concatenate(xs), np.concatenate(areas)


def capillary_dt(rho, h, sigma) -> float:
    """Capillary-wave limit dt <= 0.25 sqrt(rho h^3 / (2 pi sigma)) [s] (Brackbill et al.
    1992, eq. 61); inf without surface tension."""
    if sigma <= 0.0:
        return math.inf
    return 0.25 * math.sqrt(rho * h**3 / (2.0 * math.pi * sigma))


class AxisymmetricCSF:
    """CSF surface tension ``sigma`` [N/m] for the augmented (real + mirror) particle set of
    :class:`~sphfem.fluid.axisymmetric.AxisymmetricFluid` (module docstring).

    After :meth:`accumulate`, ``state`` (a :class:`~sphfem.fluid.surface_tension_csf.CSFState`
    over the augmented rows) holds g, omega, kappa (= kappa_m + kappa_h) and kbar, and
    ``kappa_m`` / ``kappa_h`` the two parts.  ``hoop=False``: no hoop part (the planar CSF
    with a symmetry plane at r = 0, for the planar mode of the fluid).
    """

    def __init__(self, sigma: float, kernel_code: int = kernels.WENDLAND_C2,
                 axis_band=AXIS_BAND, hoop: bool = True):
        if not sigma >= 0.0:
            raise ValueError(f"surface tension sigma must be >= 0, got {sigma}")
        self.sigma = float(sigma)
        self.kernel_code = int(kernel_code)
        self.axis_band = tuple(float(a) for a in axis_band)
        self.hoop = bool(hoop)
        self.state = None
        self.kappa_m = self.kappa_h = np.zeros(0)

    def accumulate(self, x, A, rho, kind, offsets, indices, n, src, mtype, R, Lz, acc):
        """acc[:n] += CSF acceleration of the real rows.  ``x``, ``A``, ``rho``, ``kind``:
        the augmented set (rows n + q are the mirrors of ``src[q]`` of type ``mtype[q]``,
        fields already filled), its neighbour list ``offsets`` / ``indices`` (radius >= R),
        scalar support ``R``, z period ``Lz`` (0: open)."""
        m = x.shape[0]
        st = self.state = csf_state(self.state, m, 2)
        kc = colour_kinds(kind)
        period = np.array([0.0, float(Lz)])
        ks = kernels.kernel_sigma(self.kernel_code, 2, R)
        kcode = self.kernel_code
        csf_normals(x, A, kc, offsets, indices, R, ks, kcode, period, NORMAL_LO, NORMAL_HI,
                    st.g, st.omega)
        mirror_normals(n, src, mtype, st.g, st.omega)
        csf_curvature(x, A, kc, offsets, indices, R, ks, kcode, period, TANGENT_MIN, st.g,
                      st.omega, st.kappa)
        self.kappa_m = st.kappa.copy()
        kh = np.zeros(m)
        a, b = self.axis_band
        if self.hoop:
            hoop_curvature(np.abs(x[:, 0]), st.g, st.omega, self.kappa_m, a * R, b * R, kh)
        self.kappa_h = kh
        st.kappa += kh
        mirror_scalar(n, src, st.kappa)
        work = np.zeros((m, 2))
        csf_force(x, A, rho, kc, offsets, indices, R, ks, kcode, period, self.sigma,
                  DELTA_FACTOR, SHEPARD_MIN, st.g, st.omega, st.kappa, st.kbar, work)
        acc[:n] += work[:n]
        return st
