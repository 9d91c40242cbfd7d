"""Exceptions shared by sphfem's layers; this module imports nothing of sphfem, so any
module (geometry, the scene schema, physics packages) can raise them without importing
the module that catches them.
"""

from __future__ import annotations

__all__ = ["SceneError"]


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
