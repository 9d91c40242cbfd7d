"""Particle lattices for TL-SPH bodies: cell-centred points of a box, clamp layers."""

from __future__ import annotations

import numpy as np


def box_lattice(lo, hi, dx: float) -> np.ndarray:
    """Cell-centred lattice points filling the box [lo, hi] with spacing ``dx`` (each
    particle owns a dx^dim cell; the box sides must be multiples of dx)."""
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    counts = np.rint((hi - lo) / dx).astype(int)
    if np.any(counts < 1) or np.any(np.abs(counts * dx - (hi - lo)) > 1e-9 * (hi - lo)):
        raise ValueError(f"box sides {hi - lo} must be positive multiples of dx = {dx}")
    axes = [lo[k] + dx * (np.arange(counts[k]) + 0.5) for k in range(lo.size)]
    return np.ascontiguousarray(np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
                                .reshape(-1, lo.size))
