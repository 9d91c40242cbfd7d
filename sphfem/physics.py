"""The physics-module protocol and the registry of modules a scene can name.

A module is a small object that declares the per-particle fields it needs, initialises
itself once the particles exist, reports its stable time step and advances the state by
``dt``; it sees the run through a narrow :class:`~sphfem.context.StepContext`, not the
driver (docs/architecture.md).  The registry maps the scene name to an import path, so
that only the modules a scene lists are imported, built, allocated and stepped.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from sphfem.particles import ParticleSet

#: scene name -> "module.path:ClassName" (imported only when a scene names it)
MODULES: dict[str, str] = {}
#: (scene name, geometry) -> target: the class built instead of ``MODULES[name]`` in a
#: scene whose ``[scene] geometry`` is not "cartesian" (e.g. "axisymmetric")
GEOMETRY_MODULES: dict[tuple[str, str], str] = {}


def register_physics(name: str, target: str, geometry: str = "cartesian") -> None:
    """Register the physics module class at ``target`` ("pkg.mod:Class") as ``name``; with
    ``geometry`` (a ``[scene] geometry`` value other than "cartesian") as the form of
    ``name`` built in scenes of that geometry."""
    if geometry == "cartesian":
        MODULES[name] = target
    else:
        GEOMETRY_MODULES[(name, geometry)] = target


def snapshot_attrs(obj, names) -> dict:
    """Independent copies of the attributes ``names`` of ``obj`` (a module's checkpoint
    state: :meth:`PhysicsModule.checkpoint_state`)."""
    import copy

    return {a: copy.deepcopy(getattr(obj, a)) for a in names}


class PhysicsModule:
    """Base class of physics modules (heat conduction, WCSPH fluid, TL-SPH solid, ...).

    Subclasses set ``name`` and override the hooks.  Every hook receives the run's
    :class:`~sphfem.context.StepContext` (particles, neighbour list, kernel, domain, time,
    output folder, materials), never the driver.  The driver calls, in order:

    ``fields()``  once, to allocate the per-particle arrays;
    ``init(ctx)``  once the particles and the first list exist (again after a resumed
        checkpoint); it may return particles to append (kind GHOST, derived from the
        others: a resumed run drops them and ``init`` places them anew);
    ``appended(ctx, index)``  when ``init`` returned particles: the driver appended them
        (now at ``index``) and rebuilt the list once;
    ``start(ctx)``  when the run starts (``ctx.out`` is the output folder);
    each step ``dt_limits(ctx)``, then ``step(ctx, dt)`` with ``ctx.t`` the time at the
    start of the step; ``reorder(ctx, perm)`` after a cell sort; ``diagnostics(ctx)``.
    """

    name = "base"
    #: True if the module moves particles (the driver then keeps a Verlet-skin list and
    #: checks it before each step; inside its step the module asks ``ctx.neighbors()``)
    moves_particles = False
    #: attributes saved in a checkpoint by the default :meth:`checkpoint_state`: the
    #: module's running records (histories, accumulated impulses, peaks) that ``init``
    #: cannot rebuild from the particles
    checkpoint_attrs: tuple[str, ...] = ()

    def __init__(self, scene):
        self.scene = scene

    def fields(self) -> dict[str, tuple[np.dtype, int]]:
        """Per-particle arrays this module needs: name -> (dtype, components)."""
        return {}

    def init(self, ctx) -> ParticleSet | None:
        """Deferred initialisation, after particles and the neighbour list exist; return
        the particles to append (kind GHOST) or None."""
        return None

    def appended(self, ctx, index: np.ndarray) -> None:
        """The particles ``init`` returned are appended at ``index``; the list is rebuilt."""

    def start(self, ctx) -> None:
        """The run starts: ``ctx.out`` is the output folder (write the initial records)."""

    def dt_limits(self, ctx) -> dict[str, float]:
        """Named stable-time-step limits in seconds (e.g. {"thermal": 1e-6})."""
        return {}

    def step(self, ctx, dt: float) -> None:
        """Advance this module's state by ``dt``."""
        raise NotImplementedError

    def reorder(self, ctx, perm: np.ndarray) -> None:
        """The driver permuted every particle field (new index k holds old ``perm[k]``).

        Modules keep per-particle state in ``ctx.particles`` only; a module that caches
        particle indices (ghost sources, say) remaps them here.
        """

    def diagnostics(self, ctx) -> dict:
        """JSON-serialisable figures for summary.json (fallback counts, energy drift, ...)."""
        return {}

    def checkpoint_state(self, ctx) -> dict | None:
        """The module's own state that is not in the particle fields (histories, running
        peaks, a substrate's temperature field), as picklable plain data, or None when it
        has none.  The driver stores it in the checkpoint and hands it to
        :meth:`restore_state` after ``init`` on a resumed run.  Default: copies of the
        attributes named in :attr:`checkpoint_attrs`."""
        if not self.checkpoint_attrs:
            return None
        return snapshot_attrs(self, self.checkpoint_attrs)

    def restore_state(self, ctx, state: dict) -> None:
        """Take back what :meth:`checkpoint_state` returned (after ``init``)."""
        for a, v in state.items():
            setattr(self, a, v)


def build_modules(scene) -> list[PhysicsModule]:
    """Instantiate the modules listed in ``scene.physics.modules``, in that order (in a
    scene of another geometry its registered form, :data:`GEOMETRY_MODULES`)."""
    out = []
    geometry = getattr(scene, "geometry", "cartesian")
    for name in scene.physics.modules:
        try:
            target = GEOMETRY_MODULES.get((name, geometry)) or MODULES[name]
        except KeyError:
            raise KeyError(f"physics module {name!r} is not registered") from None
        mod_name, cls_name = target.split(":")
        cls = getattr(importlib.import_module(mod_name), cls_name)
        out.append(cls(scene))
    return out
