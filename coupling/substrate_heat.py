"""The substrate's heat in the coupled job: ``[coupling.heat] model = "fem-contact"``.

``model = "sph"`` (default) is the original path: the substrate's SPH particles conduct heat
with the fluid (pair conduction across the wall, Cleary) and their temperatures are mapped
to the FEM nodes for the thermal stress.  A pair carries ~k (T_f - T_s)/dx, so while the
thermal layers are thinner than dx (water: sqrt(alpha_f t) < 1 um over an impact) it
under-predicts both the contact temperature and the heat (validation case ``contact-heat``).

``model = "fem-contact"`` (this module):

1. the substrate's temperature is a transient FEM conduction
   (:class:`sphfem.fem.heat_transient.TransientHeat`, backward Euler, lumped capacity) on a
   mesh graded in depth (:func:`~sphfem.fem.heat_transient.graded_mesh`; first cell
   ``h_surface``, geometric ``growth``, ``depth`` >= 8 sqrt(alpha_s t_end) so that the
   insulated bottom is not felt, lateral cells ``h_lateral``);
2. the SPH wall conduction is switched off: k = 0 on every particle of the coupled material
   (its wall particles and their heat ghosts; the Cleary harmonic mean
   2 k_i k_j / (k_i + k_j) is then 0 on every fluid-wall pair), so the fluid exchanges heat
   with the wall only through
3. the conservative contact interface :class:`coupling.heat_interface.ContactHeatInterface`,
   called once per coupling step (after the ``heat`` module, before the substrate solve)
   over the coupling interval dt_c: dE = itf.step(x_f, T_f, V_f, dt_c, h=dx) and
   T_f -= dE / (m_f c_f), so the heat the fluid loses equals the heat the FEM takes in to
   round-off (eq. 5 there);
4. the thermal strain of the stress substrate takes its temperatures from that FEM heat
   field (interpolated at the stress mesh's temperature nodes inside the heat mesh; T0
   outside it), not from the particle-to-node map;
5. ``diagnostics`` (summary.json, ``diagnostics.coupling.substrate_heat``): the interface's
   figures, the FEM energy residual, the surface temperature history at the impact point,
   the heat into the substrate, and for reference the ideal contact of two semi-infinite
   bodies (Carslaw & Jaeger 1959, sec. 2.15):

       T_i = (e_f T_f + e_s T_s) / (e_f + e_s),   e = sqrt(k rho c),
       Q_ideal = sum_a A_a 2 C sqrt(t - t_wet,a),  C = e_f e_s (T_f - T_s) / ((e_f + e_s) sqrt(pi)),

   Q_ideal accumulated step by step over the run's own wetted-area history (each surface
   node from the time it was wetted: A_a 2 C (sqrt(t_w + dt) - sqrt(t_w)) per wetted step).

Axisymmetric runs: the same code takes ring volumes 2 pi r A and full-ring masses of an
axisymmetric SPH fluid (``vol`` and ``m`` as stored on its particles): a scene with
``[scene] geometry = "axisymmetric"`` (sphfem.axisymmetric_scene) gets an axisymmetric heat
mesh (2 pi r-weighted forms) and the impact point on the axis.
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np

from sphfem.schema import CUSTOM, Param, Section

logger = logging.getLogger(__name__)

__all__ = ["HEAT_SECTION", "SubstrateHeat", "TensorProbe", "build_substrate_heat", "check_heat",
           "heat_defaults"]

MODELS = ("sph", "fem-contact")
_FEM = ("fem-contact",)


def _lateral(v, ctx, key):
    n = ctx.dim - 1
    ok = (isinstance(v, list) and len(v) == n and all(
        isinstance(p, list) and len(p) == 2
        and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in p)
        and p[1] > p[0] for p in v))
    if not ok:
        ctx.error(key, f"expected {n} pair(s) [lo, hi] (m, lo < hi), one per lateral axis "
                       f"of the coupled surface, e.g. {[[-1e-4, 1e-4]] * n}, got {v!r}")
    return tuple((float(a), float(b)) for a, b in v)


def check_heat(rec, ctx, path, material, backend):
    """Cross-key rules of ``[coupling.heat]`` ``rec`` (called from the ``[coupling]``
    check with the section's ``material`` and ``backend``)."""
    if rec.model != "fem-contact":
        return
    core = ctx.core
    if backend not in ("fem", "fem-dynamic", "fem-axisymmetric"):
        ctx.error(f"{path}.model", f'model = "fem-contact" needs coupling.backend = "fem", '
                                   f"got {backend!r}")
    mods = list(core["physics"].modules)
    if "heat" not in mods:
        ctx.error(f"{path}.model", 'model = "fem-contact" exchanges heat with the fluid '
                                   'particles: list "heat" in physics.modules')
    mats = core.get("materials", {})
    blocks = core.get("blocks", ())
    fluid = sorted({b.material for b in blocks if b.kind == "fluid"})
    if not fluid:
        ctx.error(f"{path}.model", 'model = "fem-contact" needs a fluid block')
    if len(fluid) > 1:
        ctx.error(f"{path}.model", f'model = "fem-contact" takes one fluid material, the '
                                   f"scene has {fluid}")
    for name in fluid + [material]:
        if name not in mats:
            continue
        for k in ("k", "c", "rho0"):
            if mats[name][k] is None:
                ctx.error(f"materials.{name}.{k}", f'missing: model = "fem-contact" needs '
                                                   f"{k} of material {name!r}")


HEAT_SECTION = Section("heat", (
    Param("model", str, "sph", choices=MODELS,
          doc='substrate heat: "sph" (its SPH particles conduct with the fluid, their '
              'temperatures mapped to the FEM nodes) or "fem-contact" (transient FEM '
              "conduction on a mesh graded in depth, fed by the conservative contact "
              "flux of coupling.heat_interface each coupling step; SPH wall conduction "
              "off; the stress substrate's thermal strain from that field)"),
    Param("lateral", CUSTOM, None, convert=_lateral, when=("model", _FEM),
          type_doc="list of dim - 1 pairs [lo, hi] (m)",
          default_doc="the SPH solid region's lateral extent",
          doc="lateral extent of the heat mesh per lateral axis of the coupled surface; "
              "fluid beyond it exchanges no heat (`uncovered_wall_particles_max` in "
              "summary.json)"),
    Param("depth", float, None, unit="m", positive=True, quantity="length",
          when=("model", _FEM), default_doc="8 sqrt(alpha_s `[time] t_end`)",
          doc="depth of the heat mesh below the coupled surface (insulated bottom; "
              "8 layer thicknesses keep it unfelt: erfc(4) = 1.5e-8)"),
    Param("h_surface", float, None, unit="m", positive=True, quantity="mesh size",
          when=("model", _FEM), default_doc="sqrt(alpha_s t_end / 100) / 3",
          doc="first cell below the surface (three cells across the substrate's layer at "
              "1 % of the run; about 0.1 um for the droplet job)"),
    Param("growth", float, 1.15, bounds=(1.0, 2.0), when=("model", _FEM),
          doc="ratio of neighbouring cells in depth (1.1-1.2 keeps the graded layer accurate)"),
    Param("h_lateral", float, None, unit="m", positive=True, quantity="mesh size",
          when=("model", _FEM), default_doc="`[sph] dx` / 2",
          doc="uniform lateral cell size (each particle footprint spans >= 2 cells)"),
    Param("wet_fraction", float, 0.5, gt=0.0, le=1.0, when=("model", _FEM),
          doc="a surface node becomes wetted when the footprints of the fluid's first cell "
              "layer (coupling.heat_interface) cover this fraction of its area; it stays "
              "wetted while the fluid within two cells of the wall covers any of it"),
    Param("layer", str, "strained", choices=("stagnant", "strained", "strained-viscous"),
          when=("model", _FEM),
          doc="the fluid's thermal layer in the contact closure: \"strained\" (stretched "
              "by the wall-parallel flow, d(s^2)/dt = alpha_f - 2 a s^2 with a the "
              "divergence of the wall layer's tangential velocity, coupling.heat_interface "
              "eq. 6: a spreading droplet's layer stops growing; identical to \"stagnant\" "
              "for fluid at rest), \"strained-viscous\" (the same under the viscous "
              "stagnation-point layer of a no-slip wall: the outer strain read from the "
              "wall cells' strain through the Hiemenz/Homann profile; needs the fluid's mu; "
              "sphfem.heat.stagnation_layer) or \"stagnant\" (grows as sqrt(alpha_f t) from "
              "wetting whatever the flow)"),
    Param("strain_radius", float, 3.0, positive=True, when=("model", _FEM),
          doc="radius of the least-squares fit of the wall layer's tangential velocity "
              "that gives the strain of layer = \"strained\", in particle sizes"),
    Param("robin_tol", float, lambda dim: 1.0 if dim == 3 else 0.1, positive=True,
          when=("model", _FEM), default_doc="1.0 (3D), 0.1 (2D)",
          doc="refactorise the FEM matrix when a node's exchange conductance moved by more "
              "than this fraction of C/dt + H0 (TransientHeat.robin_tol; larger: fewer LU "
              "factorisations)"),
), doc="Heat in the substrate (`[coupling.heat]`): the SPH substrate particles' own "
       'conduction (`model = "sph"`) or the transient FEM conduction with the contact-flux '
       'interface (`model = "fem-contact"`, coupling.substrate_heat).')


# ----------------------------------------------------------------------------- set-up


def heat_defaults(hcfg, dim: int, dx: float, t_end: float, k: float, rho: float, c: float,
                  region_lo, region_hi) -> dict:
    """The mesh parameters of ``[coupling.heat]`` with the defaults filled in (see the
    section's docs): lateral, depth, h_surface, growth, h_lateral."""
    alpha = k / (rho * c)
    lateral = hcfg.lateral
    if lateral is None:
        lateral = tuple((float(region_lo[a]), float(region_hi[a])) for a in range(dim - 1))
    layer = math.sqrt(alpha * t_end)
    return {"lateral": tuple(lateral),
            "depth": hcfg.depth if hcfg.depth is not None else 8.0 * layer,
            "h_surface": (hcfg.h_surface if hcfg.h_surface is not None
                          else math.sqrt(alpha * t_end / 100.0) / 3.0),
            "growth": float(hcfg.growth),
            "h_lateral": hcfg.h_lateral if hcfg.h_lateral is not None else 0.5 * dx}


def build_substrate_heat(scene, cfg, ctx, region):
    """The :class:`SubstrateHeat` of ``scene.coupling`` (``region``: the coupled region of
    :func:`coupling.sensors.coupled_region`), or None when ``[coupling.heat] model`` is
    "sph".  Switches the SPH wall conduction off (module docstring, 2)."""
    hcfg = cfg["heat"]
    if hcfg.model != "fem-contact":
        return None
    from coupling.heat_interface import ContactHeatInterface
    from sphfem.fem.heat_transient import TransientHeat, graded_mesh
    from sphfem.particles import FLUID

    if ctx.t > 0.0 and "coupling" not in (ctx.resumed_states or {}):
        raise ValueError('[coupling.heat] model = "fem-contact" cannot resume from this '
                         "checkpoint: it holds no substrate heat state (written by an "
                         "older sphfem); rerun from t = 0")
    t0 = time.perf_counter()
    dim = scene.dim
    sol = ctx.materials[cfg.material]
    fluid_names = sorted({b.material for b in scene.blocks if b.kind == "fluid"})
    flu = ctx.materials[fluid_names[0]]
    top = float(region.hi[-1])
    prm = heat_defaults(hcfg, dim, scene.sph.dx, scene.time.t_end, sol.k, sol.rho0, sol.c,
                        region.lo, region.hi)
    axi = getattr(scene, "geometry", "cartesian") == "axisymmetric"  # (r, z), rings
    mesh = graded_mesh(prm["lateral"], prm["depth"], prm["h_surface"], prm["growth"],
                       h_lateral=prm["h_lateral"], axisymmetric=axi)
    if top != 0.0:
        mesh = mesh.translated([0.0] * (dim - 1) + [top])
    heat = TransientHeat(mesh, sol.k, sol.rho0, sol.c, region.T0, theta=1.0,
                         robin_tol=hcfg.robin_tol, axisymmetric=axi)
    period = np.asarray(ctx.period, float).copy()
    itf = ContactHeatInterface(heat, flu.k, flu.rho0, flu.c, axis=dim - 1, level=top,
                               side=1, wet_fraction=hcfg.wet_fraction, period=period,
                               lo=np.asarray(ctx.lo, float), layer=hcfg.layer,
                               strain_radius=hcfg.strain_radius,
                               nu_f=(flu.mu / flu.rho0 if getattr(flu, "mu", None) else None))
    ps = ctx.particles
    fl = ps.kind == FLUID
    w = ps.m[fl] * ps.c_heat[fl]
    T_f = float(np.sum(w * ps.T[fl]) / np.sum(w)) if fl.any() else region.T0
    centre = (np.sum(ps.m[fl][:, None] * ps.x[fl], axis=0) / np.sum(ps.m[fl])
              if fl.any() else 0.5 * (region.lo + region.hi))
    impact = np.array(centre, float)
    impact[-1] = top
    if axi:
        impact[0] = 0.0  # the impact point is on the axis
    sh = SubstrateHeat(heat, itf, dx=scene.sph.dx, T_fluid=T_f,
                       fluid=(flu.k, flu.rho0, flu.c), impact_point=impact, params=prm)
    sh.disconnect_wall_conduction(ctx, scene.material_index(cfg.material))
    sh.setup_s = time.perf_counter() - t0
    logger.info("coupling.heat fem-contact: %d nodes (%d on the surface), first cell %.3g m, "
                "depth %.3g m", mesh.nvertices, heat.n_surface, prm["h_surface"], prm["depth"])
    return sh


# ----------------------------------------------------------------------------- runtime


class SubstrateHeat:
    """FEM heat of the substrate + contact interface, driven once per coupling step
    (module docstring).  ``heat`` a TransientHeat, ``itf`` its ContactHeatInterface,
    ``dx`` the particle size handed to the interface, ``T_fluid`` [K] the fluid's initial
    (heat-capacity weighted) temperature and ``fluid`` its (k, rho, c), for the ideal
    contact reference; ``impact_point`` the surface point whose temperature is recorded."""

    def __init__(self, heat, itf, dx: float, T_fluid: float, fluid, impact_point,
                 params: dict | None = None):
        self.heat, self.itf, self.dx = heat, itf, float(dx)
        self.T_s0 = float(heat.T.mean())
        self.T_fluid = float(T_fluid)
        kf, rf, cf = fluid
        self.e_f = math.sqrt(kf * rf * cf)
        self.e_s = math.sqrt(heat.k * heat.rho * heat.c)
        self.params = dict(params or {})
        self.impact_point = np.asarray(impact_point, float)
        self._locate = TensorProbe(heat.mesh)
        self.reference_from_initial_state()
        self.t_last: float | None = None
        self.q_ideal = 0.0
        self.history: list[dict] = []
        self.T_impact_max = self.T_s0
        self.T_impact_max_t = None
        self.uncovered_max = 0
        self.fluid_e0 = None
        self._nodal = None
        self.setup_s = 0.0
        self.timings = {"exchange": 0.0, "nodal_T": 0.0}

    def reference_from_initial_state(self) -> None:
        """The ideal contact's temperature and flux constant, and the impact point's probe
        and node, from ``T_fluid``, ``T_s0`` and ``impact_point`` (the state at t = 0; a
        resumed run restores those three from its checkpoint and calls this again: built
        from the resumed particles, the fluid's mean temperature and centre are not the
        initial ones)."""
        self.T_contact = (self.e_f * self.T_fluid + self.e_s * self.T_s0) / (self.e_f + self.e_s)
        self._C = (self.e_f * self.e_s * (self.T_fluid - self.T_s0)
                   / ((self.e_f + self.e_s) * math.sqrt(math.pi)))
        self._P_impact = self._locate(self.impact_point[None, :])
        self._impact_node = int(np.argmin(np.linalg.norm(self.itf.X - self.impact_point,
                                                         axis=1)))

    def disconnect_wall_conduction(self, ctx, material_id: int) -> None:
        """k = 0 on every particle of the coupled material (wall particles and their heat
        ghosts): the Cleary pairs with them then carry nothing.  The heat module builds its
        conductances on its next step from the new neighbour list requested here."""
        ps = ctx.particles
        sel = ps.material == material_id
        self.disconnected = int(sel.sum())
        if "k_heat" in ps:
            ps.k_heat[sel] = 0.0
        ctx.neighbors(rebuild=True)

    def _fluid(self, ps, wet_only: bool = True):
        """The fluid rows; ``wet_only``: those that can wet the substrate (rings taken out
        of the heat, k_heat = 0 -- axisymmetric debris -- cannot); all of them for the
        fluid's energy."""
        from sphfem.particles import FLUID

        fl = ps.kind == FLUID
        if wet_only and "k_heat" in ps:
            fl &= ps.k_heat != 0.0
        return np.flatnonzero(fl)

    def exchange(self, ps, t: float) -> None:
        """One coupling step ending at ``t``: exchange over t - (the previous call's t)
        (nothing on the first call) and record the figures."""
        from coupling.heat_interface import step_mean_inv_sqrt

        f = self._fluid(ps)
        if self.fluid_e0 is None:
            fa = self._fluid(ps, wet_only=False)
            self.fluid_e0 = float(np.sum(ps.m[fa] * ps.c_heat[fa] * ps.T[fa]))
        if self.t_last is None or t <= self.t_last:
            self.t_last = t if self.t_last is None else self.t_last
            return
        t0 = time.perf_counter()
        dt = t - self.t_last
        x, vol = ps.x[f], ps.vol[f]
        cap = ps.m[f] * ps.c_heat[f]
        dE = self.itf.step(x, ps.T[f], vol, dt, h=self.dx, v=ps.v[f], capacity=cap)
        ps.T[f] -= dE / cap
        self.t_last = t
        itf = self.itf
        wet = ~np.isnan(itf.t_wet)
        tw = (itf.t - dt) - itf.t_wet[wet]  # < 0: wetted inside the step
        self.q_ideal += float(np.sum(itf.sub.surface_area[wet] * self._C * dt
                                     * step_mean_inv_sqrt(tw, dt)))
        # wall-layer particles whose footprint lies off the heat mesh exchange nothing
        z = x[:, -1] - itf.level
        lat = x[:, :-1]
        near = z < 1.5 * self.dx
        lo, hi = itf._slo[:-1], itf._shi[:-1]
        per = itf.period[:-1] > 0
        off = np.any(((lat < lo) | (lat > hi)) & ~per, axis=1)
        self.uncovered_max = max(self.uncovered_max, int(np.sum(near & off)))
        T_imp = float((self._P_impact @ self.heat.T)[0])
        if T_imp > self.T_impact_max:
            self.T_impact_max, self.T_impact_max_t = T_imp, t
        self.history.append({"t": t, "T_impact": T_imp,
                             "T_surface_max": float(self.heat.surface_temperature().max()),
                             "heat_to_substrate_J": itf.heat_to_substrate,
                             "ideal_contact_heat_J": self.q_ideal,
                             "wetted_nodes": int(wet.sum()),
                             "wetted_area": float(itf.sub.surface_area[wet].sum()),
                             "strain_impact": float(itf.strain[self._impact_node])})
        self.timings["exchange"] += time.perf_counter() - t0

    def nodal_temperatures(self, targets) -> np.ndarray:
        """Temperatures [K] of the heat field at ``targets`` (n, dim): interpolated inside
        the heat mesh's box, T_s0 outside (heat enters only through the mesh)."""
        t0 = time.perf_counter()
        targets = np.asarray(targets, float)
        key = (targets.shape, targets.tobytes())
        if self._nodal is None or self._nodal[0] != key:
            p = self.heat.mesh.p
            tol = 1e-9 * float(np.max(np.ptp(p, axis=1)))
            inside = np.all((targets >= p.min(axis=1) - tol) & (targets <= p.max(axis=1) + tol),
                            axis=1)
            idx = np.flatnonzero(inside)
            P = self._locate(targets[idx]) if idx.size else None
            self._nodal = (key, idx, P)
        _, idx, P = self._nodal
        T = np.full(targets.shape[0], self.T_s0)
        if P is not None:
            T[idx] = P @ self.heat.T
        self.timings["nodal_T"] += time.perf_counter() - t0
        return T

    def reading(self, r, targets):
        """The sensor reading ``r`` with the region's temperatures replaced by the heat
        field at the backend's temperature ``targets`` (the backend copies them:
        ``temperature_map = "nodes"``)."""
        from dataclasses import replace

        T = self.nodal_temperatures(targets)
        return replace(r, x_region=np.asarray(targets, float), T_region=T,
                       vol_region=np.ones(len(T)))

    def diagnostics(self, ps=None) -> dict:
        itf, heat = self.itf, self.heat
        d = {"model": "fem-contact", "mesh": {
            "nodes": int(heat.mesh.nvertices), "cells": int(heat.mesh.nelements),
            "surface_nodes": heat.n_surface, **{k: (list(map(list, v)) if k == "lateral"
                                                      else v) for k, v in self.params.items()}},
            "interface": itf.diagnostics(),
            "energy_residual_J": heat.energy_residual(),
            "heat_to_substrate_J": itf.heat_to_substrate,
            "substrate_energy_gain_J": float(np.sum(heat.M @ (heat.T - self.T_s0))),
            "ideal_contact_temperature_K": self.T_contact,
            "ideal_contact_heat_J": self.q_ideal,
            "fluid_initial_temperature_K": self.T_fluid,
            "substrate_initial_temperature_K": self.T_s0,
            "impact_point_m": self.impact_point.tolist(),
            "T_impact_max_K": self.T_impact_max, "T_impact_max_t_s": self.T_impact_max_t,
            "uncovered_wall_particles_max": self.uncovered_max,
            "sph_particles_disconnected": getattr(self, "disconnected", None),
            "wall_s": {"setup": self.setup_s, **self.timings},
            "history": self.history}
        if ps is not None and self.fluid_e0 is not None:
            f = self._fluid(ps, wet_only=False)
            lost = self.fluid_e0 - float(np.sum(ps.m[f] * ps.c_heat[f] * ps.T[f]))
            d["heat_lost_by_fluid_J"] = lost
            d["fluid_substrate_residual_rel"] = ((lost - itf.heat_to_substrate)
                                                 / max(abs(itf.heat_to_substrate), 1e-300))
        return d


class TensorProbe:
    """P1 interpolation matrix (points x nodes) on a simplex mesh of a tensor grid
    (:func:`~sphfem.fem.heat_transient.graded_mesh`): each point's grid cell by a search
    per axis, then the barycentric coordinates in the cell's simplices (2 triangles / 6
    tetrahedra), the one containing it taken (coordinates clipped to >= 0 and renormalised
    for round-off at faces; points outside the grid are clipped onto it).  Memory and time
    O(points); scikit-fem's generic finder holds a (points x elements) array, 4.7 GB for
    the stress mesh's nodes in a 3D heat mesh of 21k nodes."""

    def __init__(self, mesh):
        p, t = mesh.p, mesh.t
        self.dim = p.shape[0]
        self.n = p.shape[1]
        self.axes = [np.unique(p[a]) for a in range(self.dim)]
        self.shape = tuple(len(ax) - 1 for ax in self.axes)
        if int(np.prod([len(ax) for ax in self.axes])) != self.n:
            raise ValueError("TensorProbe: the mesh is not a tensor grid")
        self.p, self.t = p, t
        cen = self._index(p)[:, t].mean(axis=1)
        cell = np.ravel_multi_index(tuple(np.floor(cen).astype(np.int64)), self.shape)
        counts = np.bincount(cell, minlength=int(np.prod(self.shape)))
        if counts.min() != counts.max():
            raise ValueError("TensorProbe: cells with different numbers of simplices")
        self.cells = np.argsort(cell, kind="stable").reshape(counts.size, counts[0])

    def _index(self, X):
        """Coordinates (dim, n) -> fractional grid indices (affine inside every cell)."""
        return np.stack([np.interp(X[a], ax, np.arange(len(ax), dtype=float))
                         for a, ax in enumerate(self.axes)])

    def __call__(self, points):
        import scipy.sparse as sp

        X = np.atleast_2d(np.asarray(points, float))
        m, d = X.shape[0], self.dim
        Q = self._index(X.T)  # barycentric coordinates are those of the index space
        c = np.clip(np.floor(Q).astype(np.int64), 0, np.array(self.shape)[:, None] - 1)
        cand = self.cells[np.ravel_multi_index(tuple(c), self.shape)]  # (m, k)
        P = self._index(self.p)
        V = P[:, self.t[:, cand]]                       # (d, d + 1, m, k)
        A = np.moveaxis(V[:, 1:] - V[:, :1], (0, 1), (-2, -1))  # (m, k, d, d)
        r = np.moveaxis(Q[:, :, None] - V[:, 0], 0, -1)          # (m, k, d)
        lam = np.linalg.solve(A, r[..., None])[..., 0]
        lam = np.concatenate([1.0 - lam.sum(-1, keepdims=True), lam], axis=-1)
        best = np.argmax(lam.min(-1), axis=1)
        lam = np.maximum(lam[np.arange(m), best], 0.0)
        lam /= lam.sum(axis=1, keepdims=True)
        el = cand[np.arange(m), best]
        rows = np.repeat(np.arange(m), d + 1)
        return sp.csr_matrix((lam.ravel(), (rows, self.t[:, el].T.ravel())),
                             shape=(m, self.n))
