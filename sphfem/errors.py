"""Exceptions shared by sphfem's layers: scene mistakes, stopped runs, refused outputs.

This module imports nothing of sphfem, so any module (geometry, the scene schema, physics
packages, the coupling) can raise them without importing the module that catches them (a
physics module never imports the driver, :mod:`sphfem.simulation`).  The old homes
re-export them: ``sphfem.schema.SceneError``, ``sphfem.simulation.SimulationStopped``,
``sphfem.output.OutputExistsError``.
"""

from __future__ import annotations

__all__ = ["OutputExistsError", "OutputFolderError", "SceneError", "SimulationStopped"]


class SceneError(ValueError):
    """A mistake in a scene: ``str()`` is one line ``source: key: message``."""

    def __init__(self, source: str, key: str, message: str):
        self.source = str(source)
        self.key = str(key).encode("unicode_escape").decode("ascii")  # always one line
        self.message = " ".join(str(message).split())
        super().__init__(str(self))

    def __str__(self) -> str:
        parts = [p for p in (self.source, self.key, self.message) if p]
        return ": ".join(parts)

    def __reduce__(self):
        return (type(self), (self.source, self.key, self.message))


class SimulationStopped(Exception):
    """A stability guard stopped the run (the last state was written before raising).

    Physics modules raise it from ``step`` with a message naming the step, the time, what
    tripped and the likely cause; the driver records it as status ``"stopped"``.
    """


class OutputExistsError(Exception):
    """The output folder exists and ``--overwrite`` was not given."""


class OutputFolderError(OSError):
    """The output folder cannot be created (a parent is a file or not writable, or the
    old contents cannot be removed); ``str()`` is one line ``folder: cannot create the
    output folder: why``."""
