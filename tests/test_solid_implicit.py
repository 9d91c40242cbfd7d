"""Newton-Krylov solves of the TL-SPH body (:mod:`sphfem.solid.implicit`): the exact
linearisation, the assembled tangent, the quasi-static solve against dynamic relaxation,
the implicit trapezoidal step against the fixed-point one, its order and energy beyond the
explicit limit, the substrate's ``solver`` and the module's ``newton`` / ``implicit``."""

from __future__ import annotations

import numpy as np
import pytest

from sphfem.solid import implicit
from sphfem.solid.body import SolidBody
from sphfem.solid.constitutive import lame
from sphfem.solid.integrate import trapezoid_step, verlet_step
from sphfem.solid.lattice import box_lattice

E, NU, RHO, DX = 300e9, 0.21, 3950.0, 10e-6


def _bar(L=20, H=4, hourglass=10.0, alpha=0.0):
    """Alumina bar (plane strain), L x H particles, clamped on 3 layers at x < 0, tip load
    down on the last column."""
    X = box_lattice((-3 * DX, 0.0), (L * DX, H * DX), DX)
    lam, mu = lame(E, NU)
    b = SolidBody(X, DX * DX, RHO, lam, mu, alpha, DX, hourglass=hourglass)
    b.clamp(X[:, 0] < 0)
    tip = X[:, 0] > (L - 1) * DX
    b.f_ext[tip] = (0.0, -1e6 * DX * H / tip.sum())
    return b, tip


@pytest.mark.parametrize("hourglass", [0.0, 10.0])
def test_force_differential_is_the_derivative(hourglass):
    """d f_int against central differences at a deformed, heated state: the error falls as
    h^2 (100x per decade of h) down to 1e-8."""
    b, _ = _bar(hourglass=hourglass, alpha=8e-6)
    b.theta[:] = 60.0
    x = b.x + 1e-3 * DX * np.sin(b.ref.X / (5 * DX))
    rng = np.random.default_rng(3)
    d = rng.standard_normal(x.shape)
    b.internal_forces(x)
    lin = implicit.force_differential(b, x, d)
    errs = []
    for h in (1e-3, 1e-4):
        e = h * DX / np.abs(d).max()
        fd = (b.internal_forces(x + e * d).copy() - b.internal_forces(x - e * d).copy()) / (2 * e)
        errs.append(np.linalg.norm(fd - lin) / np.linalg.norm(lin))
    b.internal_forces(x)
    assert errs[1] < 1e-7
    assert errs[0] / errs[1] > 50.0


def test_tangent_is_the_linearisation_and_pair_stiffness_is_symmetric():
    b, _ = _bar()
    x = b.x + 1e-3 * DX * np.cos(b.ref.X / (4 * DX))
    K = implicit.tangent_stiffness(b, x)
    free = ~b.fixed.ravel()
    v = np.random.default_rng(0).standard_normal(K.shape[0])
    d = np.zeros(b.x.size)
    d[free] = v
    b.internal_forces(x)
    ref = -implicit.force_differential(b, x, d.reshape(x.shape)).ravel()[free]
    assert np.linalg.norm(K @ v - ref) <= 1e-12 * np.linalg.norm(ref)
    Kp = implicit.pair_stiffness(b)
    assert abs(Kp - Kp.T).max() == 0.0
    # rigid translations cost nothing
    t = np.tile([1.0, 0.0], b.n)
    assert np.abs(Kp @ t).max() <= 1e-12 * abs(Kp).max()


@pytest.mark.parametrize("dim", [2, 3])
def test_static_solve_matches_relaxation(dim):
    """Newton-Krylov and dynamic relaxation reach the same equilibrium (thermal load plus a
    point load; mirror roller planes, i.e. ghosts, in 3D), both stopped at relative
    residual 1e-6: against a Newton solve to 1e-8, Newton's displacements are within 1e-5
    of their maximum and closer than relaxation's, which are within 1e-3."""
    from sphfem.solid.backend import TLSPHSubstrate

    if dim == 2:
        kw = dict(lo=(0.0, 0.0), hi=(20 * DX, 5 * DX), clamps=["left"])
        face = "right"
    else:
        kw = dict(lo=(0.0, 0.0, 0.0), hi=(8 * DX, 6 * DX, 4 * DX), clamps=["bottom"],
                  rollers={"left": "x", "front": "y"})
        face = "top"
    res = []
    for solver, tol in (("newton", 1e-6), ("relax", 1e-6), ("newton", 1e-8)):
        s = TLSPHSubstrate(dx=DX, E=E, nu=NU, alpha=8e-6, rho=RHO, solver=solver, tol=tol,
                           **kw)
        at = s.body.ref.X[s.face_layer[face]][-1:]
        f = np.zeros((1, dim))
        f[0, -1] = -0.05
        res.append(s.solve(dT_nodal=lambda Y: 50.0 * (Y[0] / (8 * DX)) ** 2,
                           point_forces=(at, f), snap=face))
        assert res[-1].info["converged"] and res[-1].info["residual"] <= tol
        assert s.diagnostics()["solver"] == solver
    new, rel, tight = res
    scale = np.abs(tight.u).max()
    e_new = np.abs(new.u - tight.u).max() / scale
    e_rel = np.abs(rel.u - tight.u).max() / scale
    assert e_new <= 1e-5 and e_new < e_rel <= 1e-3
    with pytest.raises(ValueError, match="solver"):
        TLSPHSubstrate(dx=DX, E=E, nu=NU, alpha=0.0, solver="cg", **kw)


def test_static_solve_keeps_an_exact_state_and_reports_failure():
    b, _ = _bar()
    info = implicit.static_solve(b, tol=1e-6)
    assert info["converged"] and info["newton"] <= 3
    again = implicit.static_solve(b, tol=1e-6)  # warm start at the solution: nothing to do
    assert again["steps"] == 0
    b2, _ = _bar()
    with pytest.raises(implicit.SolidConvergenceError, match="Newton-Krylov static"):
        implicit.static_solve(b2, tol=1e-6, max_newton=1, gmres_maxiter=1, gmres_restart=1)
    assert np.array_equal(b2.x, b2.ref.X)  # state restored


def test_newmark_step_solves_the_trapezoidal_equations():
    """Below the explicit limit the fixed-point trapezoid converges: the Newton-Krylov step
    solves the same equations, so both agree to their tolerances."""
    b1, _ = _bar()
    b2, _ = _bar()
    dt = 0.3 * b1.stable_dt(0.9)
    for k in range(10):
        trapezoid_step(b1, dt, tol=1e-12, step_index=k)
        implicit.newmark_step(b2, dt, tol=1e-12)
    scale = np.abs(b1.u).max()
    assert np.abs(b1.u - b2.u).max() <= 1e-8 * scale
    assert np.abs(b1.v - b2.v).max() <= 1e-6 * np.abs(b1.v).max()


def _released(hourglass=10.0):
    """The bar at its static deflection under the tip load, load removed, at rest."""
    b0, tip = _bar(hourglass=hourglass)
    implicit.static_solve(b0, tol=1e-7)
    x0 = b0.x.copy()

    def fresh():
        b, _ = _bar(hourglass=hourglass)
        b.f_ext[:] = 0.0
        b.x[:] = x0
        b.a = b.accelerations()
        return b

    return fresh, tip, np.abs(x0 - b0.ref.X).max()


def _energy(b):
    b.internal_forces()
    return b.strain_energy() + b.hourglass_energy() + b.kinetic_energy()


def test_newmark_step_accuracy_below_and_beyond_the_explicit_limit():
    """Free vibration from the static deflection (every mode excited), tip deflection
    after 200 explicit limits against velocity Verlet at 1/8 of the limit: at 1 and 2 x
    the limit the implicit step is as accurate as Verlet at 0.8 x (within 1.5x of its
    error); beyond, the modes with omega dt > 2 are no longer resolved and the error grows
    with the step (measured 0.29 / 0.61 / 1.07 % of the amplitude at 5 / 10 / 20 x) but
    stays bounded (< 2 %), where Verlet at 10 x diverges."""
    fresh, tip, amp = _released()
    lim = fresh().stable_dt(1.0)
    T = 200 * lim

    def tip_error(step, dt):
        b = fresh()
        for _ in range(int(round(T / dt))):
            step(b, dt)
        return abs(b.u[tip, 1].mean() - u_ref) / amp

    ref = fresh()
    for _ in range(int(round(T / (lim / 8)))):
        verlet_step(ref, lim / 8)
    u_ref = ref.u[tip, 1].mean()
    e_verlet = tip_error(verlet_step, 0.8 * lim)

    def newmark(b, dt):
        info = implicit.newmark_step(b, dt, tol=1e-10)
        assert info["newton"] <= 4

    errs = [tip_error(newmark, f * lim) for f in (1, 2, 5, 10, 20)]
    assert errs[0] <= 1.5 * e_verlet and errs[1] <= 1.5 * e_verlet
    assert errs[1] < errs[2] < errs[3] < errs[4] < 0.02
    bad = fresh()
    with np.errstate(all="ignore"):
        for _ in range(20):
            verlet_step(bad, 10 * lim)
    assert not np.isfinite(bad.u).all() or np.abs(bad.u).max() > 1e3 * amp


def test_newmark_step_energy_beyond_the_explicit_limit():
    """Without hourglass control (a conservative body) the trapezoidal step at 20 x the
    explicit limit keeps strain + kinetic energy to 1e-6; with it, the energy bookkeeping
    of the hourglass pseudo-potential drifts (a property of the semi-discrete forces, not
    of the step): Newmark's energy then follows velocity Verlet's at 1/10 of the limit to
    1e-2 of the energy."""
    fresh, _, _ = _released(hourglass=0.0)
    b = fresh()
    lim = b.stable_dt(1.0)
    e0 = _energy(b)
    for _ in range(10):
        implicit.newmark_step(b, 20 * lim, tol=1e-10)
        assert abs(_energy(b) - e0) <= 1e-6 * e0
    fresh, _, _ = _released(hourglass=10.0)
    b, v = fresh(), fresh()
    e0 = _energy(b)
    for _ in range(10):
        implicit.newmark_step(b, 20 * lim, tol=1e-10)
        for _ in range(200):
            verlet_step(v, 0.1 * lim)
        assert abs(_energy(b) - _energy(v)) <= 1e-2 * e0


def test_module_newton_and_implicit_integrators(tmp_path):
    """The ``[tlsph]`` integrators ``newton`` (quasi-static) and ``implicit`` (Newmark at
    10 x the limit) through the scene driver: ``newton`` gives relax's state."""
    from test_solid_module import ROLLERS, body_arrays, scene

    from sphfem.simulation import Simulation

    out = {}
    for integ in ("relax", "newton"):
        sim = Simulation(scene(bcs=ROLLERS, tlsph=f'integrator = "{integ}"'))
        summary = sim.run(tmp_path / integ, progress=False)
        out[integ] = body_arrays(sim)
        d = summary["diagnostics"]["tlsph"]
        assert d["integrator"] == integ and d["relax_residual"] <= 1e-6
    scale = np.abs(out["relax"][2]).max()
    assert np.abs(out["relax"][2] - out["newton"][2]).max() <= 1e-4 * scale
    # suddenly heated, undamped: the implicit steps (10 x the limit) oscillate about the
    # static state, within twice its displacement
    sim = Simulation(scene(bcs=ROLLERS, tlsph='integrator = "implicit"', t_end=2e-5))
    summary = sim.run(tmp_path / "implicit", progress=False)
    d = summary["diagnostics"]["tlsph"]
    assert d["integrator"] == "implicit" and d["steps"] >= 5 and d["max_iterations"] >= 1
    u_static = np.abs(out["newton"][1]).max()
    u = body_arrays(sim)[1]
    assert np.isfinite(u).all() and 0.0 < np.abs(u).max() <= 2.0 * u_static


def test_amg_and_direct_preconditioners_give_the_same_static_state():
    """The 3D pair-stiffness preconditioner by sparse LU and by the AMG V-cycle (used above
    ``direct_max`` unknowns): the same equilibrium to the solve's tolerance."""
    from sphfem.solid.backend import TLSPHSubstrate

    us = []
    for direct_max in (10**6, 0):
        s = TLSPHSubstrate((0.0, 0.0, 0.0), (8 * DX, 8 * DX, 4 * DX), DX, E, NU, 8e-6,
                           rho=RHO, clamps=["bottom"], tol=1e-8)
        b = s.body
        b.__dict__["_nk_precond"] = {(0.0, b.fixed.tobytes()):
                                     implicit.Preconditioner(b, 0.0, direct_max=direct_max)}
        s._set_loads(lambda Y: 40.0 * np.exp(-((Y[0] - 4 * DX) ** 2) / (3 * DX) ** 2), None,
                     None, None)
        info = implicit.static_solve(b, tol=1e-8)
        assert info["converged"]
        assert info["preconditioner"] == ("splu" if direct_max else "amg")
        us.append(b.u.copy())
    assert np.abs(us[0] - us[1]).max() <= 1e-6 * np.abs(us[0]).max()
