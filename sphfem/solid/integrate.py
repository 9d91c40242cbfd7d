"""Time integration of a :class:`~sphfem.solid.body.SolidBody`.

* :func:`verlet_step` -- velocity Verlet (kick-drift-kick), second order, symplectic without
  damping; stable for dt omega_max < 2 (:meth:`SolidBody.stable_dt`).  Optional viscous
  damping ``body.damping`` (a -= c v, treated semi-implicitly in the second kick).
* :func:`trapezoid_step` -- implicit trapezoidal rule (Park 2019 sec. 2.5.5, eqs.
  2.130-2.137, alg. 2.8) solved by fixed-point iteration

      x^{k+1} = x^t + dt v^t + dt^2/4 (a(x^k, v^k) + a^t)
      v^{k+1} = v^t + dt/2 (a(x^k, v^k) + a^t)

  until max(|x^{k+1} - x^k|, dt |v^{k+1} - v^k|) <= tol dx.  The first guess is the
  explicit predictor x^t + dt v^t + dt^2/2 a^t (the thesis uses x^t; both are valid starts).
  The iteration map has Lipschitz constant ~ (dt omega_max)^2 / 4 on the stiffest mode, so
  it converges only for dt omega_max < 2 -- the explicit limit: fixed-point iteration does
  not buy a larger step on stiff solids (a Newton-Krylov solve would).  When it does not
  converge, the state is restored and :class:`SolidConvergenceError` names the step, the
  residual history and the iteration count.  The temperature is advanced first by the heat
  solver (one-way coupling: theta does not depend on x, v), so the thesis' extended system
  (eq. 2.138) reduces to this one with theta^{t+1} known.
* :func:`relax` -- dynamic relaxation to the quasi-static state (Underwood 1983 adaptive
  damping): damped leapfrog with the critical damping c = 2 omega_min of the lowest
  excited mode, omega_min^2 estimated each step by the Rayleigh quotient
  u.(f0 - f(u)) / u.M u of the displacement u since the start (exact for a linear
  response).  Converged when ||f_int + f_ext|| (free components) <= tol * ||load||, the
  load being the out-of-balance force of the undeformed body under the current loads
  (floored at the load of a 1e-7 strain, see the code).
"""

from __future__ import annotations

import time

import numpy as np


class SolidConvergenceError(RuntimeError):
    """The implicit step or the relaxation did not converge (state restored)."""


def verlet_step(body, dt: float) -> None:
    """One velocity-Verlet step (uses ``body.a`` from the previous step if present)."""
    a0 = getattr(body, "a", None)
    if a0 is None or a0.shape != body.x.shape:
        a0 = body.accelerations()
    c = body.damping
    v = body.v
    v += 0.5 * dt * a0
    held = body.fixed
    v[held] = body.v_presc[held]
    body.x += dt * v
    a1 = body.accelerations(v=np.zeros_like(v))  # damping added below, semi-implicitly
    v += 0.5 * dt * a1
    if c > 0.0:
        v /= (1.0 + c * dt)
    v[held] = body.v_presc[held]
    body.a = a1 - c * v if c > 0.0 else a1
    body.a[held] = 0.0


def trapezoid_step(body, dt: float, tol: float = 1e-9, max_iter: int = 200,
                   step_index: int | None = None, diverge_factor: float = 1e3) -> dict:
    """One implicit trapezoidal step by fixed-point iteration; returns
    ``{"iterations": k, "residual": r}`` or raises :class:`SolidConvergenceError`."""
    a0 = getattr(body, "a", None)
    if a0 is None or a0.shape != body.x.shape:
        a0 = body.accelerations()
    x_t, v_t = body.x.copy(), body.v.copy()
    held = body.fixed
    xk = x_t + dt * v_t + 0.5 * dt * dt * a0
    vk = v_t + dt * a0
    xk[held] = x_t[held] + dt * body.v_presc[held]
    vk[held] = body.v_presc[held]
    scale = body.dx
    history = []
    for k in range(1, max_iter + 1):
        ak = body.accelerations(xk, vk)
        x_new = x_t + dt * v_t + 0.25 * dt * dt * (ak + a0)
        v_new = v_t + 0.5 * dt * (ak + a0)
        x_new[held] = xk[held]
        v_new[held] = vk[held]
        r = max(float(np.max(np.abs(x_new - xk))),
                dt * float(np.max(np.abs(v_new - vk)))) / scale
        history.append(r)
        xk, vk = x_new, v_new
        if not np.isfinite(r) or (k > 3 and r > diverge_factor * history[0]):
            break
        if r <= tol:
            body.x[:] = xk
            body.v[:] = vk
            body.a = body.accelerations()
            return {"iterations": k, "residual": r}
    body.x[:] = x_t
    body.v[:] = v_t
    body.internal_forces()
    where = f"step {step_index}" if step_index is not None else "trapezoidal step"
    shown = ", ".join(f"{h:.3g}" for h in history[:3])
    if len(history) > 3:
        shown += f", ..., {history[-1]:.3g}"
    raise SolidConvergenceError(
        f"TL-SPH implicit trapezoidal {where}: fixed-point iteration did not converge "
        f"after {len(history)} iterations (residual |dx|/dx: {shown}; tol {tol:g}) at "
        f"dt = {dt:.3g} s.  The iteration contracts only for dt * omega_max < 2 (the "
        f"explicit limit, see SolidBody.stable_dt); reduce dt.  State restored to the "
        f"start of the step.")


def relax(body, tol: float = 1e-6, max_steps: int = 200000, dt: float | None = None,
          check_every: int = 10, raise_on_fail: bool = True) -> dict:
    """Dynamic relaxation of ``body`` to static equilibrium under its current loads and
    temperature (held components keep their positions).  Returns a dict with steps,
    residual (relative), wall seconds; raises :class:`SolidConvergenceError` after
    ``max_steps`` unless ``raise_on_fail`` is False."""
    t0 = time.perf_counter()
    dt = body.stable_dt(0.9) if dt is None else dt
    free = ~body.fixed
    m = body.m[:, None]
    x_start = body.x.copy()
    # load scale: out-of-balance force of the undeformed body
    f_ref = (body.internal_forces(body.ref.X.copy()) + body.f_ext) * free
    load = float(np.linalg.norm(f_ref))
    f0 = (body.internal_forces() + body.f_ext) * free
    # floor: the load of a strain of 1e-7 on every particle, sqrt(n) E dx^(dim-1) 1e-7, so
    # that tol * floor stays far above the round-off forces (~ sqrt(n) E dx^(dim-1) 1e-15):
    # round-off-level loads (a mapped temperature equal to T0 to 1e-14 K) count as no load
    floor = 1e-7 * np.sqrt(body.n) * float(body.young.max()) * body.dx ** (body.dim - 1)
    load = max(load, floor)
    v = np.zeros_like(body.x)
    steps = 0
    res = float(np.linalg.norm(f0)) / load
    f = f0
    while steps < max_steps:
        if steps % check_every == 0:
            res = float(np.linalg.norm(f)) / load
            if res <= tol:
                break
            if not np.isfinite(res):
                break
        u = body.x - x_start
        den = float(np.sum(m * u * u))
        num = float(np.sum(u * (f0 - f)))
        w2 = num / den if den > 0 and num > 0 else 0.0
        c = min(2.0 * np.sqrt(w2), 1.9 / dt)
        v *= (1.0 - 0.5 * c * dt)
        v += dt * f / m
        v /= (1.0 + 0.5 * c * dt)
        v[~free] = 0.0
        body.x += dt * v
        f = (body.internal_forces() + body.f_ext) * free
        steps += 1
    res = float(np.linalg.norm(f)) / load
    body.v[:] = 0.0
    body.a = np.zeros_like(body.x)
    info = {"steps": steps, "residual": res, "converged": bool(res <= tol),
            "dt": dt, "wall_s": time.perf_counter() - t0}
    if not info["converged"] and raise_on_fail:
        raise SolidConvergenceError(
            f"TL-SPH dynamic relaxation: residual {res:.3g} > tol {tol:g} after {steps} "
            f"steps (dt {dt:.3g} s)")
    return info
