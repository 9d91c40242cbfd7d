"""The on-disk cache of derived inputs (meshes, Poisson-disk samples).

Folder: ``$SPHFEM_CACHE`` or ``~/.cache/sphfem``, one subfolder per kind.  An entry's name
is a hash of everything that determines it (parameters, recipe version, library versions),
so a cached entry is the exact result the computation would give again; entries are
written atomically (temporary file, rename), so concurrent runs never read a partial one.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np


def cache_root() -> Path:
    """``$SPHFEM_CACHE`` or ``~/.cache/sphfem``."""
    return Path(os.environ.get("SPHFEM_CACHE") or os.path.join(Path.home(), ".cache", "sphfem"))


def cache_key(params: dict) -> str:
    """16 hex digits of the SHA-256 of ``params`` as sorted JSON."""
    text = json.dumps(params, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def cached_array(kind: str, params: dict, compute: Callable[[], np.ndarray]) -> np.ndarray:
    """``compute()``, stored under ``cache_root()/kind`` by the hash of ``params`` and read
    back on later calls with equal ``params``.  A cache that cannot be written (read-only
    home, full disk) only costs the recomputation."""
    path = cache_root() / kind / f"{cache_key(params)}.npy"
    try:
        return np.load(path, allow_pickle=False)
    except (OSError, ValueError):
        pass
    x = compute()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        with open(tmp, "wb") as f:
            np.save(f, x, allow_pickle=False)
        os.replace(tmp, path)
    except OSError:
        pass
    return x
