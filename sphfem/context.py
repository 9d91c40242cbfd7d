"""What a physics module sees of a run: the narrow :class:`StepContext`.

The driver (:class:`sphfem.simulation.Simulation`) owns one context and passes it to every
hook of every module (:class:`sphfem.physics.PhysicsModule`) in place of itself.  A module
reads and writes particle fields and reads the rest; it never replaces the particle set or
builds a list.  Structural changes are requested, not done:

* particles to add (heat's ghost particles) are *returned* from ``init``; the driver
  appends them, rebuilds the list once and calls the module's ``appended`` hook;
* a module that moves particles inside its step asks for a valid list with
  :meth:`StepContext.neighbors` (the driver rebuilds when some particle moved more than
  skin R / 2 since the last build, and may cell-sort, calling every module's ``reorder``);
  a new list is seen by its ``nbrs_version``, the one counter of list builds.

Materials come from the scene (``materials``: name -> material record, in scene order, so a
particle's ``material`` id indexes ``list(materials)``), the output folder is ``out``
(None until the run starts: during set-up nothing is written).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from sphfem.neighbors import NeighborList
    from sphfem.particles import ParticleSet

__all__ = ["StepContext"]


@dataclass(eq=False)
class StepContext:
    """The state a physics module works on.

    ``particles``: the structure of arrays (fields in place; the driver may permute or
    extend it between hooks, so do not keep field arrays across steps);
    ``R`` [m] the kernel's support radius, ``sigma`` its normalisation (W = sigma f(R, q)),
    ``kernel_code`` (:func:`sphfem.kernels.kernel_code` of ``kernel``, the scene's name);
    ``lo``, ``hi`` [m] the domain box and ``period`` [m] the periodic lengths (0 = open);
    ``materials`` the scene's materials; ``moving``: some module moves particles (the list
    is then a Verlet-skin list, pairs within (1 + skin) R); ``t`` [s] and ``step`` the time
    and the number of steps taken; ``out`` the run's output folder (None during set-up);
    ``nbrs`` the current neighbour list and ``nbrs_version`` the number of lists built.
    """

    particles: ParticleSet
    R: float
    sigma: float
    kernel_code: int
    kernel: str
    lo: np.ndarray
    hi: np.ndarray
    period: np.ndarray
    materials: Mapping[str, Any]
    moving: bool = False
    t: float = 0.0
    step: int = 0
    out: Path | None = None
    nbrs: NeighborList | None = None
    nbrs_version: int = 0
    #: the pair filter ``nbrs`` was built with (keep masks by kind, as
    #: :func:`sphfem.neighbors.build_neighbor_list` takes them; None: all pairs)
    pair_filter: tuple | None = None
    #: the driver's list service: ``provide(rebuild)`` makes ``nbrs`` valid for the
    #: current positions (rebuild=True: build anew now)
    provide: Callable[[bool], None] | None = field(default=None, repr=False)
    #: on a resumed run, the modules' saved states by module name
    #: (:meth:`sphfem.physics.PhysicsModule.checkpoint_state`), set before their ``init``
    resumed_states: dict | None = field(default=None, repr=False)

    @property
    def dim(self) -> int:
        return self.particles.dim

    @property
    def kernel_args(self) -> tuple:
        """(x, vol, offsets, indices, R, sigma, kernel_code, period): the common tail of
        the operators in :mod:`sphfem.operators`."""
        p, nl = self.particles, self.nbrs
        return (p.x, p.vol, nl.offsets, nl.indices, self.R, self.sigma, self.kernel_code,
                self.period)

    def neighbors(self, rebuild: bool = False) -> NeighborList:
        """A neighbour list valid for the current positions (every pair closer than R).

        ``rebuild``: particles were moved outside the stepping (packing before the first
        step), build the list anew.  Without a driver (a context made by hand) the list is
        built here with radius R when missing or on ``rebuild``.
        """
        if self.provide is not None:
            self.provide(rebuild)
        elif rebuild or self.nbrs is None:
            from sphfem.neighbors import build_neighbor_list

            self.nbrs = build_neighbor_list(self.particles.x, self.R, self.lo, self.hi,
                                            self.period)
            self.nbrs_version += 1
        return self.nbrs
