"""A scene at another resolution: every length that sets a resolution scaled by one factor.

Used by convergence studies (``sphfem validate droplet-impact``) and by the cold-cache
compile of :mod:`sphfem.jit_warmup`.  The lengths scaled are ``[sph] dx``, a block's ``dx``
and its ``gap`` (a gap is checked against the kernel radius R = support_factor dx, so it
scales with it) and every ``h_*`` key of a module's sub-table (``[coupling.mesh] h_fine``,
``[coupling.heat] h_surface``, ...): refining the particles and the meshes together keeps
the ratio of the two discretisations, so a sequence of factors is one refinement path
(the figures then converge at the order of the slower of the two).
"""

from __future__ import annotations

__all__ = ["scaled_resolution"]


def scaled_resolution(scene, factor: float) -> dict:
    """``scene`` (a :class:`sphfem.scene.Scene`) as a dict that ``parse_scene`` accepts,
    with every resolution length (module docstring) times ``factor`` (> 0; < 1 refines)."""
    if not factor > 0:
        raise ValueError(f"scaled_resolution: factor must be > 0, got {factor!r}")
    d = scene.to_dict()
    d["sph"]["dx"] *= factor
    for b in d["blocks"]:
        for k in ("dx", "gap"):
            if b.get(k) is not None:
                b[k] *= factor
    for name in scene.sections:
        for sub in d[name].values():
            if isinstance(sub, dict):
                for k, v in sub.items():
                    if (k.startswith("h_") and isinstance(v, (int, float))
                            and not isinstance(v, bool) and v):
                        sub[k] = v * factor
    return d
