"""``TLSPHModule``: the ``tlsph`` physics module (protocol of :mod:`sphfem.physics`).

The body is the set of particles of the ``[tlsph] blocks`` (default: every block of kind
``"solid"``) in the driver's shared particle set.  On ``init`` the module records each body
particle's reference position (field ``X0``), stress-free temperature (``T_ref``) and body
index (``tl_id`` = index + 1; 0 for particles outside the body) and builds a
:class:`~sphfem.solid.body.SolidBody` on the reference positions: its neighbour list,
kernel gradients and correction tensors are in *body order* (the order of the particle
``id``) and are kept for the run.  The driver may permute the particle set (cell sort,
ghosts appended by the heat module, a checkpoint reload); the module maps body order to
the current particle indices through ``tl_id``, so the reference data never need a
rebuild -- :meth:`TLSPHModule.reorder` remaps the cached map, which is also re-derived
from ``tl_id`` whenever the particle arrays were replaced.

Each step copies x, v and the temperature T of the body particles into the body, advances
it with the chosen integrator and writes x, v, the displacement ``u``, the Cauchy stress
``stress`` (3x3, row-major; 2D: plane strain, sigma_zz included) and ``von_mises`` back.

Integrators (``[tlsph] integrator``):

* ``verlet`` -- :func:`~sphfem.solid.integrate.verlet_step`; the step limit ``explicit`` =
  cfl x 2/omega_max (power iteration on the particle stiffness at the start);
* ``trapezoid`` -- :func:`~sphfem.solid.integrate.trapezoid_step` at ``dt`` (default the
  same limit); a step that does not converge stops the run with the iteration history, or
  (``on_failure = "substep"``) is redone as explicit Verlet sub-steps and counted;
* ``relax`` -- quasi-static: :func:`~sphfem.solid.integrate.relax` to equilibrium under the
  loads of the step (temperature, tractions), warm-started from the previous state;
* ``newton`` -- quasi-static as ``relax``, solved by Newton-Krylov
  (:func:`~sphfem.solid.implicit.static_solve`, same convergence test on ``relax_tol``);
* ``implicit`` -- the trapezoidal rule of ``trapezoid`` solved by Newton-Krylov
  (:func:`~sphfem.solid.implicit.newmark_step`) at any ``dt`` (default 10 x the explicit
  limit); ``tol`` bounds the position error of the solve (in dx).

Energies in the diagnostics (per unit depth in 2D): kinetic, strain (free energy of the
SVK material), hourglass (pseudo-potential of the hourglass forces), external potential
-f_ext . u of the constant tractions, and their sum; the sum is conserved by undamped
Verlet at constant temperature up to O(dt^2) and the hourglass term's approximation (its
largest drift from the start is reported; heating and damping change it by design).
"""

from __future__ import annotations

import numpy as np

from sphfem.errors import SimulationStopped
from sphfem.particles import SOLID
from sphfem.physics import PhysicsModule
from sphfem.solid.scene_section import body_blocks

_AXES = "xyz"


class TLSPHModule(PhysicsModule):
    name = "tlsph"
    moves_particles = True

    def __init__(self, scene):
        super().__init__(scene)
        self.cfg = scene.tlsph
        if self.cfg is None:  # pragma: no cover - the scene lists the module
            raise ValueError("the tlsph module needs the scene's [tlsph] section")
        self.body = None

    def fields(self):
        d = self.scene.dim
        return {"v": (np.float64, d), "T": (np.float64, 1), "X0": (np.float64, d),
                "u": (np.float64, d), "T_ref": (np.float64, 1), "tl_id": (np.int64, 1),
                "stress": (np.float64, 9), "von_mises": (np.float64, 1)}

    # -- set-up --------------------------------------------------------------------------
    def _block_members(self, ps) -> dict[str, np.ndarray]:
        """Particle indices of each body block, from the stable particle ids (the driver
        builds the blocks in scene order, ids consecutive per block)."""
        from sphfem.geometry import block_points

        sc = self.scene
        counts = [block_points(sc, i).shape[0] for i in range(len(sc.blocks))]
        starts = np.concatenate([[0], np.cumsum(counts)])
        ids = ps.id
        out = {}
        for name in self.block_names:
            i = sc.block_index(name)
            sel = np.flatnonzero((ids >= starts[i]) & (ids < starts[i + 1]))
            sel = sel[np.argsort(ids[sel], kind="stable")]
            mat = sc.material_index(sc.blocks[i].material)
            if (sel.size != counts[i] or np.any(ps.kind[sel] != SOLID)
                    or np.any(ps.material[sel] != mat)):
                raise ValueError(f"tlsph: the particles of block {name!r} cannot be "
                                 "identified (the particle set was not built from this "
                                 "scene's blocks)")
            out[name] = sel
        return out

    def init(self, ctx) -> None:
        from sphfem.solid.body import SolidBody
        from sphfem.solid.constitutive import lame

        sc, cfg = self.scene, self.cfg
        ps = ctx.particles
        self.block_names = body_blocks(cfg.blocks, sc.blocks)
        members = self._block_members(ps)
        fresh = not np.any(ps.tl_id > 0)
        if fresh:
            idx = np.concatenate([members[n] for n in self.block_names])
            ps.X0[idx] = ps.x[idx]
            ps.T_ref[idx] = (ps.T[idx] if cfg.T0 is None else cfg.T0)
            ps.tl_id[idx] = np.arange(1, idx.size + 1)
        else:  # re-init after a checkpoint: the body order is stored in tl_id
            sel = np.flatnonzero(ps.tl_id > 0)
            idx = np.empty(sel.size, np.int64)
            idx[ps.tl_id[sel] - 1] = sel
        self._idx, self._tl_arr = idx, ps.tl_id
        # body index of every member particle
        where = np.full(ps.n, -1, np.int64)
        where[idx] = np.arange(idx.size)
        mats = [sc.materials[m] for m in sc.material_names]
        mid = ps.material[idx]
        E = np.array([mats[k].E for k in mid], float)
        nu = np.array([mats[k].nu for k in mid], float)
        alpha = np.array([mats[k].alpha or 0.0 for k in mid], float)
        lam, mu = lame(E, nu)
        dxs = [sc.blocks[sc.block_index(n)].dx or sc.sph.dx for n in self.block_names]
        self.dx = float(max(dxs))
        X0 = np.ascontiguousarray(ps.X0[idx])
        body = SolidBody(X0, ps.vol[idx], ps.rho[idx], lam, mu, alpha, self.dx,
                         theta0=ps.T_ref[idx].copy(),
                         support_factor=sc.sph.support_factor,
                         kernel=sc.sph.kernel, period=ctx.period,
                         hourglass=cfg.hourglass, damping=cfg.damping)
        body.x[:] = ps.x[idx]
        body.v[:] = ps.v[idx]
        body.theta[:] = ps.T[idx]
        self._boundaries(body, members, where, ps)
        self.body = body
        # explicit limit at the starting state
        self.omega_max = body.omega_max()
        self.dt_explicit = cfg.cfl * 2.0 / self.omega_max if self.omega_max > 0 else np.inf
        self.stats = {"steps": 0, "iterations": 0, "max_iterations": 0, "fallbacks": 0,
                      "fallback_substeps": 0, "relax_steps": 0, "max_relax_steps": 0,
                      "relax_residual": None, "peak_von_mises_Pa": 0.0,
                      "peak_von_mises_t": 0.0}
        body.a = body.accelerations()
        self._write(ps, ctx.t)
        self.energy0 = self._energy()
        self.max_drift = 0.0

    def _boundaries(self, body, members, where, ps) -> None:
        sc = self.scene
        self.bc_counts = []
        for b in self.cfg.boundaries:
            blk = sc.blocks[sc.block_index(b.block)]
            sel = members[b.block]
            bi = where[sel]
            X = body.ref.X[bi]
            dxb = blk.dx or sc.sph.dx
            if b.face == "all":
                on = np.ones(sel.size, bool)
                area = None
            else:
                ax = _AXES.index(b.face[0])
                face = blk.hi[ax] if b.face.endswith("max") else blk.lo[ax]
                dist = np.abs(X[:, ax] - face)
                if b.condition == "traction":
                    on = dist < dist.min() + 0.5 * dxb
                else:
                    layers = (b.layers if b.layers is not None
                              else int(np.ceil(sc.sph.support_factor - 1e-9)))
                    on = dist < layers * dxb
                ext = np.asarray(blk.hi, float) - np.asarray(blk.lo, float)
                area = float(np.prod(np.delete(ext, ax)))
            mask = np.zeros(body.n, bool)
            mask[bi[on]] = True
            if b.condition == "clamp":
                body.clamp(mask)
            elif b.condition == "roller":
                body.roller(mask, b.components)
            else:
                total = np.asarray(b.traction, float) * area
                body.f_ext[mask] += total / int(mask.sum())
            self.bc_counts.append({"block": b.block, "face": b.face,
                                   "condition": b.condition, "particles": int(mask.sum())})

    # -- particle map ----------------------------------------------------------------------
    def _index(self, ps) -> np.ndarray:
        """Current particle index of each body particle (body order)."""
        if ps.tl_id is not self._tl_arr:
            tl = ps.tl_id
            sel = np.flatnonzero(tl > 0)
            idx = np.empty(sel.size, np.int64)
            idx[tl[sel] - 1] = sel
            if idx.size != self.body.n:
                raise RuntimeError(f"tlsph: {idx.size} body particles in the particle set, "
                                   f"expected {self.body.n}")
            self._idx, self._tl_arr = idx, tl
        return self._idx

    def reorder(self, ctx, perm) -> None:
        """The driver permuted the particles: remap the body -> particle index map (the
        reference neighbour list is in body order and stays valid)."""
        new_of_old = np.empty_like(perm)
        new_of_old[perm] = np.arange(perm.shape[0])
        self._idx = new_of_old[self._idx]
        self._tl_arr = ctx.particles.tl_id
        assert np.array_equal(self._tl_arr[self._idx], np.arange(1, self.body.n + 1))

    # -- stepping ------------------------------------------------------------------------
    def dt_limits(self, ctx) -> dict[str, float]:
        cfg = self.cfg
        if cfg.integrator == "verlet":
            return {"explicit": self.dt_explicit}
        if cfg.dt is not None:
            return {cfg.integrator: cfg.dt}
        if cfg.integrator == "trapezoid":
            return {"trapezoid": self.dt_explicit}
        if cfg.integrator == "implicit":
            return {"implicit": 10.0 * self.dt_explicit}
        return {"quasi_static": self.scene.time.t_end}

    def step(self, ctx, dt: float) -> None:
        from sphfem.solid.integrate import (
            SolidConvergenceError,
            relax,
            trapezoid_step,
            verlet_step,
        )

        cfg, body = self.cfg, self.body
        ps = ctx.particles
        idx = self._index(ps)
        body.x[:] = ps.x[idx]
        body.v[:] = ps.v[idx]
        body.theta[:] = ps.T[idx]
        st = self.stats
        if cfg.integrator == "verlet":
            verlet_step(body, dt)
        elif cfg.integrator == "trapezoid":
            try:
                info = trapezoid_step(body, dt, tol=cfg.tol, max_iter=cfg.max_iter,
                                      step_index=ctx.step)
                st["iterations"] += info["iterations"]
                st["max_iterations"] = max(st["max_iterations"], info["iterations"])
            except SolidConvergenceError as e:
                if cfg.on_failure == "stop":
                    raise SimulationStopped(str(e)) from None
                m = max(1, int(np.ceil(dt / self.dt_explicit * (1 - 1e-12))))
                body.a = body.accelerations()
                for _ in range(m):
                    verlet_step(body, dt / m)
                st["fallbacks"] += 1
                st["fallback_substeps"] += m
        elif cfg.integrator == "implicit":
            from sphfem.solid.implicit import newmark_step

            try:
                info = newmark_step(body, dt, tol=cfg.tol, step_index=ctx.step)
            except SolidConvergenceError as e:
                raise SimulationStopped(str(e)) from None
            st["iterations"] += info["newton"] + info["krylov"]
            st["max_iterations"] = max(st["max_iterations"],
                                       info["newton"] + info["krylov"])
        else:
            if cfg.integrator == "newton":
                from sphfem.solid.implicit import static_solve

                info = static_solve(body, tol=cfg.relax_tol, raise_on_fail=False)
            else:
                info = relax(body, tol=cfg.relax_tol, max_steps=cfg.relax_max_steps,
                             raise_on_fail=False)
            st["relax_steps"] += info["steps"]
            st["max_relax_steps"] = max(st["max_relax_steps"], info["steps"])
            st["relax_residual"] = info["residual"]
            if not info["converged"]:
                raise SimulationStopped(
                    f"tlsph: {cfg.integrator} solve at step {ctx.step} did not converge: "
                    f"residual {info['residual']:.3g} > relax_tol {cfg.relax_tol:g} after "
                    f"{info['steps']} steps (raise [tlsph] relax_max_steps, or check for "
                    "an unsupported body under a net load)")
        st["steps"] += 1
        ps.x[idx] = body.x
        ps.v[idx] = body.v
        self._write(ps, ctx.t + dt)
        e = self._energy()
        self.max_drift = max(self.max_drift, abs(e["total_J"] - self.energy0["total_J"]))

    def _write(self, ps, t: float) -> None:
        body = self.body
        idx = self._index(ps)
        sig = body.cauchy()
        vm = _von_mises(sig)
        ps.stress[idx] = sig.reshape(body.n, 9)
        ps.von_mises[idx] = vm
        ps.u[idx] = body.x - body.ref.X
        peak = float(vm.max()) if vm.size else 0.0
        if peak > self.stats["peak_von_mises_Pa"]:
            self.stats["peak_von_mises_Pa"] = peak
            self.stats["peak_von_mises_t"] = float(t)

    def _energy(self) -> dict:
        b = self.body
        kin = b.kinetic_energy()
        strain = b.strain_energy()
        hg = b.hourglass_energy()
        ext = -float(np.sum(b.f_ext * (b.x - b.ref.X)))
        return {"kinetic_J": kin, "strain_J": strain, "hourglass_J": hg,
                "external_potential_J": ext, "total_J": kin + strain + hg + ext}

    def diagnostics(self, ctx) -> dict:
        b = self.body
        e = self._energy()
        vm = ctx.particles.von_mises[self._index(ctx.particles)]
        scale = max(abs(self.energy0["total_J"]), e["strain_J"], e["kinetic_J"], 1e-300)
        return {
            "integrator": self.cfg.integrator,
            "particles": b.n,
            "dim": b.dim,
            "plane_strain": b.dim == 2,
            "support_radius_m": b.ref.R,
            "B0_fallbacks": b.ref.fallbacks,
            "held_components": int(b.fixed.sum()),
            "boundaries": self.bc_counts,
            "omega_max_rad_s": self.omega_max,
            "explicit_stable_dt_s": self.dt_explicit,
            "force_evaluations": b.force_evaluations,
            **self.stats,
            "max_von_mises_Pa": float(vm.max()) if vm.size else 0.0,
            "max_displacement_m": float(np.linalg.norm(b.x - b.ref.X, axis=1).max()),
            "energy": {**e, "initial_total_J": self.energy0["total_J"],
                       "max_abs_drift_J": self.max_drift,
                       "max_drift_relative": self.max_drift / scale},
        }


def _von_mises(sig):
    from sphfem.solid.constitutive import von_mises

    return von_mises(sig)
