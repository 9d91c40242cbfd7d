"""The physics-module protocol and the registry of modules a scene can name.

A module is a small object that declares the per-particle fields it needs, initialises
itself once the particles exist, reports its stable time step and advances the state by
``dt``.  The registry maps the scene name to an import path, so that only the modules a
scene lists are imported, built, allocated and stepped.
"""

from __future__ import annotations

import importlib

import numpy as np

#: scene name -> "module.path:ClassName" (imported only when a scene names it)
MODULES: dict[str, str] = {}


def register_physics(name: str, target: str) -> None:
    """Register the physics module class at ``target`` ("pkg.mod:Class") as ``name``."""
    MODULES[name] = target


class PhysicsModule:
    """Base class of physics modules (heat conduction, WCSPH fluid, TL-SPH solid, ...).

    Subclasses set ``name`` and override the hooks; the driver calls, in order,
    ``fields`` (once, to allocate arrays), ``init`` (once), then each step
    ``dt_limits`` and ``step``, and at the end ``diagnostics``.
    """

    name = "base"
    #: True if the module moves particles (the neighbour list is then rebuilt every step)
    moves_particles = False

    def __init__(self, scene):
        self.scene = scene

    def fields(self) -> dict[str, tuple[np.dtype, int]]:
        """Per-particle arrays this module needs: name -> (dtype, components)."""
        return {}

    def init(self, sim) -> None:
        """Deferred initialisation, after particles and the neighbour list exist."""

    def dt_limits(self, sim) -> dict[str, float]:
        """Named stable-time-step limits in seconds (e.g. {"thermal": 1e-6})."""
        return {}

    def step(self, sim, dt: float) -> None:
        """Advance this module's state by ``dt``."""
        raise NotImplementedError

    def reorder(self, sim, perm: np.ndarray) -> None:
        """The driver permuted every particle field (new index k holds old ``perm[k]``).

        Modules keep per-particle state in ``sim.particles`` only; a module that caches
        particle indices (ghost sources, say) remaps them here.
        """

    def diagnostics(self, sim) -> dict:
        """JSON-serialisable figures for summary.json (fallback counts, energy drift, ...)."""
        return {}


def build_modules(scene) -> list[PhysicsModule]:
    """Instantiate the modules listed in ``scene.physics.modules``, in that order."""
    out = []
    for name in scene.physics.modules:
        try:
            target = MODULES[name]
        except KeyError:
            raise KeyError(f"physics module {name!r} is not registered") from None
        mod_name, cls_name = target.split(":")
        cls = getattr(importlib.import_module(mod_name), cls_name)
        out.append(cls(scene))
    return out
