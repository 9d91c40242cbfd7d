"""gmsh recipes for substrate meshes, cached by a hash of their parameters.

Two recipes, both with named physical groups so that boundary conditions are given by name:

* :func:`substrate_block` -- a 3D box ``[x0, x0+Lx] x [y0, y0+Ly] x [z0, z0+Lz]`` (by default
  centred in x and y with its top face at z = 0), surfaces "top" (z max), "bottom", "left"
  (x min), "right", "front" (y min), "back" and the volume "substrate".  Tetrahedra
  (unstructured, refined to ``h_fine`` within ``refine_radius`` of ``refine_center`` and
  graded to ``h_coarse`` further away) or hexahedra (a structured tensor-product grid by
  extrusion, graded geometrically away from the refinement centre along each axis).
* :func:`substrate_rect` -- the 2D (plane-strain) rectangle with lines "top", "bottom",
  "left", "right" and the surface "substrate"; triangles or quadrilaterals.

Meshes are written as gmsh ``.msh`` (format 4.1) into the cache folder
(``$SPHFEM_CACHE`` or ``~/.cache/sphfem``, subfolder ``meshes``) under a name carrying the
parameter hash, and copied to ``path`` when one is given.  Writing goes through a
temporary file and an atomic rename.  :func:`mesh_command` is the ``sphfem mesh`` CLI.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import logging
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

logger = logging.getLogger(__name__)

RECIPE_VERSION = 1  # bump when a recipe changes the mesh it makes for the same parameters
FACES_3D = ("left", "right", "front", "back", "bottom", "top")  # (axis, side) order
FACES_2D = ("left", "right", "bottom", "top")


def cache_dir() -> Path:
    """Folder of cached meshes: ``$SPHFEM_CACHE/meshes`` or ``~/.cache/sphfem/meshes``."""
    from sphfem.cache import cache_root

    return cache_root() / "meshes"


def _key(recipe: str, params: dict) -> str:
    text = json.dumps({"recipe": recipe, "v": RECIPE_VERSION, **params}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _graded_axis(a: float, b: float, c: float, h_fine: float, h_coarse: float,
                 radius: float, growth: float) -> np.ndarray:
    """Node coordinates on [a, b]: spacing h_fine within ``radius`` of c, then growing by the
    factor ``growth`` per cell up to h_coarse."""

    def side(length_fine: float, length_total: float) -> list[float]:
        if length_total <= 0:
            return []
        out, s, h = [], 0.0, h_fine
        while s < length_total - 1e-12 * length_total:
            if s >= length_fine:
                h = min(h * growth, h_coarse)
            out.append(min(h, length_total - s))
            s += h
        # merge a sliver last cell into its neighbour, then rescale to the exact length
        if len(out) > 1 and out[-1] < 0.5 * out[-2]:
            out[-2] += out.pop()
        arr = np.array(out)
        return list(arr * (length_total / arr.sum()))

    c = min(max(c, a), b)
    left = side(radius, c - a)
    right = side(radius, b - c)
    steps = left[::-1] + right
    x = a + np.concatenate([[0.0], np.cumsum(steps)])
    x[-1] = b
    return x


class _Gmsh:
    """Context manager around gmsh.initialize/finalize (quiet, no signal handler)."""

    def __init__(self, nthreads: int | None = None):
        self.nthreads = nthreads

    def __enter__(self):
        import gmsh

        self.owner = not gmsh.isInitialized()
        if self.owner:
            gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", self.nthreads or os.cpu_count() or 1)
        gmsh.model.add(f"sphfem-{os.getpid()}-{time.monotonic_ns()}")
        return gmsh

    def __exit__(self, *exc):
        import gmsh

        gmsh.model.remove()
        if self.owner:
            gmsh.finalize()


def _name_boundaries(gmsh, dim: int, lo, hi, volume_name="substrate") -> None:
    """Physical groups for the faces (dim-1) of an axis-aligned box, plus the domain."""
    names = FACES_3D if dim == 3 else FACES_2D
    groups: dict[str, list[int]] = {n: [] for n in names}
    span = np.asarray(hi, float) - np.asarray(lo, float)
    for _, tag in gmsh.model.getEntities(dim - 1):
        # exact extent from the entity's corner points: getBoundingBox pads by the geometry
        # tolerance (~1e-7 model units), which is 0.1 % of a 0.1 mm box
        corners = gmsh.model.getBoundary([(dim - 1, tag)], combined=False, recursive=True)
        xyz = np.array([gmsh.model.getValue(0, t, []) for d, t in corners if d == 0])
        bmin, bmax = xyz.min(axis=0)[:dim], xyz.max(axis=0)[:dim]
        ext = (bmax - bmin) / span
        ax = int(np.argmin(ext))  # a face of the box is flat along exactly one axis
        if ext[ax] > 1e-3:
            continue
        mid = 0.5 * (bmin[ax] + bmax[ax])
        side = 0 if abs(mid - lo[ax]) < abs(mid - hi[ax]) else 1
        groups[names[2 * ax + side]].append(tag)
    for n, tags in groups.items():
        if not tags:
            raise RuntimeError(f"mesh recipe: no boundary entity found for face {n!r}")
        gmsh.model.addPhysicalGroup(dim - 1, tags, name=n)
    gmsh.model.addPhysicalGroup(dim, [t for _, t in gmsh.model.getEntities(dim)],
                                name=volume_name)


def _write_cached(recipe: str, params: dict, build, path=None) -> Path:
    key = _key(recipe, params)
    folder = cache_dir()
    folder.mkdir(parents=True, exist_ok=True)
    cached = folder / f"{recipe}-{key}.msh"
    if cached.exists():
        logger.info("mesh cache hit %s", cached)
    else:
        from sphfem.output import file_mode
        from sphfem.progress import stage

        t0 = time.perf_counter()
        with stage(f"meshing substrate (gmsh {recipe}, cached afterwards)"), \
                _Gmsh(params.get("nthreads")) as gmsh:
            build(gmsh)
            fd, tmp = tempfile.mkstemp(prefix=f".{cached.stem}.", suffix=".msh", dir=folder)
            os.close(fd)
            try:
                gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
                gmsh.option.setNumber("Mesh.Binary", 0)
                gmsh.write(tmp)
                os.chmod(tmp, file_mode())  # mkstemp made it 0600
                os.replace(tmp, cached)
            finally:
                if os.path.exists(tmp):
                    os.unlink(tmp)
        meta = {"recipe": recipe, "params": params, "seconds": time.perf_counter() - t0}
        from sphfem.output import write_json

        write_json(cached.with_suffix(".json"), meta)
        logger.info("meshed %s in %.2f s -> %s", recipe, meta["seconds"], cached)
    if path is None:
        return cached
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    os.close(fd)
    shutil.copyfile(cached, tmp)
    from sphfem.output import file_mode

    os.chmod(tmp, file_mode())
    os.replace(tmp, path)
    return path


def _check(size, h_fine, h_coarse, order, element, allowed):
    if any(s <= 0 for s in size):
        raise ValueError(f"mesh: size must be positive, got {size}")
    if not 0 < h_fine <= h_coarse:
        raise ValueError(f"mesh: need 0 < h_fine <= h_coarse, got {h_fine}, {h_coarse}")
    if order not in (1, 2):
        raise ValueError(f"mesh: order must be 1 or 2, got {order}")
    if element not in allowed:
        raise ValueError(f"mesh: element must be one of {allowed}, got {element!r}")


def substrate_block(path=None, size=(2e-3, 2e-3, 0.26e-3), h_fine=20e-6, h_coarse=150e-6,
                    refine_center=None, refine_radius=0.25e-3, order=1, element="tet",
                    origin=None, growth=1.3, nthreads=None) -> Path:
    """Mesh a rectangular substrate block and return the ``.msh`` path (cached).

    ``origin`` is the minimum corner (default ``(-Lx/2, -Ly/2, -Lz)``: top face at z = 0,
    centred on the z axis); ``refine_center`` defaults to the centre of the top face.
    Tetrahedra: size h_fine within ``refine_radius`` of the centre, rising linearly to
    h_coarse at ``refine_radius + (h_coarse/h_fine) * h_fine / (growth - 1)``.  Hexahedra: a
    tensor-product grid, h_fine within ``refine_radius`` of the centre along each axis,
    growing by ``growth`` per cell up to h_coarse.  ``order=2`` writes second-order
    elements (tetra10 / hexahedron27).
    """
    size = tuple(float(s) for s in size)
    _check(size, h_fine, h_coarse, order, element, ("tet", "hex"))
    Lx, Ly, Lz = size
    origin = tuple(map(float, origin)) if origin is not None else (-Lx / 2, -Ly / 2, -Lz)
    lo = np.array(origin)
    hi = lo + np.array(size)
    center = (tuple(map(float, refine_center)) if refine_center is not None
              else (lo[0] + Lx / 2, lo[1] + Ly / 2, hi[2]))
    params = dict(size=size, h_fine=float(h_fine), h_coarse=float(h_coarse),
                  refine_center=center, refine_radius=float(refine_radius), order=int(order),
                  element=element, origin=origin, growth=float(growth))

    def build(gmsh):
        if element == "tet":
            gmsh.model.occ.addBox(*origin, *size)
            gmsh.model.occ.synchronize()
            pt = gmsh.model.occ.addPoint(*center)
            gmsh.model.occ.synchronize()
            f_d = gmsh.model.mesh.field.add("Distance")
            gmsh.model.mesh.field.setNumbers(f_d, "PointsList", [pt])
            f_t = gmsh.model.mesh.field.add("Threshold")
            gmsh.model.mesh.field.setNumber(f_t, "InField", f_d)
            gmsh.model.mesh.field.setNumber(f_t, "SizeMin", h_fine)
            gmsh.model.mesh.field.setNumber(f_t, "SizeMax", h_coarse)
            gmsh.model.mesh.field.setNumber(f_t, "DistMin", refine_radius)
            gmsh.model.mesh.field.setNumber(
                f_t, "DistMax", refine_radius + (h_coarse - h_fine) / (growth - 1.0))
            gmsh.model.mesh.field.setAsBackgroundMesh(f_t)
            for opt in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints",
                        "MeshSizeFromCurvature"):
                gmsh.option.setNumber(f"Mesh.{opt}", 0)
            gmsh.option.setNumber("Mesh.Algorithm3D", 10)  # HXT: parallel Delaunay
        else:
            _extrude_grid(gmsh, lo, hi, center, h_fine, h_coarse, refine_radius, growth)
        _name_boundaries(gmsh, 3, lo, hi)
        gmsh.model.mesh.generate(3)
        if order == 2:
            gmsh.model.mesh.setOrder(2)
        # the refinement point (tet) must not leave an orphan vertex in the mesh file
        gmsh.option.setNumber("Mesh.SaveAll", 0)

    return _write_cached("substrate_block", params, build, path)


def _extrude_grid(gmsh, lo, hi, center, h_fine, h_coarse, radius, growth):
    """Structured quad/hex grid by successive extrusion (point -> line -> surface -> volume)."""
    dim = len(lo)
    axes = [_graded_axis(lo[i], hi[i], center[i], h_fine, h_coarse, radius, growth)
            for i in range(dim)]
    p = gmsh.model.geo.addPoint(*lo, *([0.0] * (3 - dim)))
    ent = [(0, p)]
    for ax in range(dim):
        x = axes[ax]
        d = [0.0, 0.0, 0.0]
        d[ax] = x[-1] - x[0]
        heights = list((x[1:] - x[0]) / (x[-1] - x[0]))
        out = gmsh.model.geo.extrude(ent, *d, numElements=[1] * len(heights),
                                     heights=heights, recombine=True)
        ent = [out[1]]  # the entity one dimension up
    gmsh.model.geo.synchronize()


def substrate_rect(path=None, size=(2e-3, 0.26e-3), h_fine=20e-6, h_coarse=150e-6,
                   refine_center=None, refine_radius=0.25e-3, order=1, element="tri",
                   origin=None, growth=1.3, nthreads=None) -> Path:
    """2D (plane-strain) substrate: rectangle with lines top/bottom/left/right, surface
    "substrate"; ``element`` "tri" (unstructured, graded as the tet block) or "quad"
    (structured, graded as the hex block).  Default origin ``(-Lx/2, -Ly)``: top at y = 0."""
    size = tuple(float(s) for s in size)
    _check(size, h_fine, h_coarse, order, element, ("tri", "quad"))
    Lx, Ly = size
    origin = tuple(map(float, origin)) if origin is not None else (-Lx / 2, -Ly)
    lo = np.array(origin)
    hi = lo + np.array(size)
    center = (tuple(map(float, refine_center)) if refine_center is not None
              else (lo[0] + Lx / 2, hi[1]))
    params = dict(size=size, h_fine=float(h_fine), h_coarse=float(h_coarse),
                  refine_center=center, refine_radius=float(refine_radius), order=int(order),
                  element=element, origin=origin, growth=float(growth))

    def build(gmsh):
        if element == "tri":
            gmsh.model.occ.addRectangle(*origin, 0.0, *size)
            gmsh.model.occ.synchronize()
            pt = gmsh.model.occ.addPoint(*center, 0.0)
            gmsh.model.occ.synchronize()
            f_d = gmsh.model.mesh.field.add("Distance")
            gmsh.model.mesh.field.setNumbers(f_d, "PointsList", [pt])
            f_t = gmsh.model.mesh.field.add("Threshold")
            gmsh.model.mesh.field.setNumber(f_t, "InField", f_d)
            gmsh.model.mesh.field.setNumber(f_t, "SizeMin", h_fine)
            gmsh.model.mesh.field.setNumber(f_t, "SizeMax", h_coarse)
            gmsh.model.mesh.field.setNumber(f_t, "DistMin", refine_radius)
            gmsh.model.mesh.field.setNumber(
                f_t, "DistMax", refine_radius + (h_coarse - h_fine) / (growth - 1.0))
            gmsh.model.mesh.field.setAsBackgroundMesh(f_t)
            for opt in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints",
                        "MeshSizeFromCurvature"):
                gmsh.option.setNumber(f"Mesh.{opt}", 0)
        else:
            _extrude_grid(gmsh, lo, hi, center, h_fine, h_coarse, refine_radius, growth)
        _name_boundaries(gmsh, 2, lo, hi)
        gmsh.model.mesh.generate(2)
        if order == 2:
            gmsh.model.mesh.setOrder(2)

    return _write_cached("substrate_rect", params, build, path)


def mesh_command(argv=None) -> int:
    """``sphfem mesh block|rect --out FILE [options]``: write a substrate mesh (.msh).

    Lengths in metres.  Prints the written path and the node/element counts as JSON.
    Returns 0 on success, 2 on bad arguments.
    """
    p = argparse.ArgumentParser(prog="sphfem mesh", description=mesh_command.__doc__.split("\n")[0])
    p.add_argument("shape", choices=("block", "rect"), help="3D block or 2D rectangle")
    p.add_argument("--out", help="output .msh (default: the cache path, printed)")
    p.add_argument("--size", type=float, nargs="+", help="Lx Ly [Lz] (default 2 2 0.26 mm)")
    p.add_argument("--h-fine", type=float, default=20e-6)
    p.add_argument("--h-coarse", type=float, default=150e-6)
    p.add_argument("--refine-center", type=float, nargs="+", default=None)
    p.add_argument("--refine-radius", type=float, default=0.25e-3)
    p.add_argument("--growth", type=float, default=1.3)
    p.add_argument("--order", type=int, choices=(1, 2), default=1)
    p.add_argument("--element", default=None, help="tet|hex (block), tri|quad (rect)")
    try:
        a = p.parse_args(argv)
    except SystemExit as e:
        return 2 if e.code else 0
    kw = dict(h_fine=a.h_fine, h_coarse=a.h_coarse, refine_center=a.refine_center,
              refine_radius=a.refine_radius, order=a.order, growth=a.growth)
    try:
        if a.shape == "block":
            size = tuple(a.size) if a.size else (2e-3, 2e-3, 0.26e-3)
            if len(size) != 3:
                raise ValueError("block: --size needs Lx Ly Lz")
            out = substrate_block(a.out, size=size, element=a.element or "tet", **kw)
        else:
            size = tuple(a.size) if a.size else (2e-3, 0.26e-3)
            if len(size) != 2:
                raise ValueError("rect: --size needs Lx Ly")
            out = substrate_rect(a.out, size=size, element=a.element or "tri", **kw)
    except ValueError as e:
        print(f"sphfem mesh: error: {e}", file=sys.stderr)
        return 2
    from sphfem.fem.substrate import read_quiet

    m = read_quiet(out)
    counts: dict[str, int] = {}
    for c in m.cells:
        counts[c.type] = counts.get(c.type, 0) + int(len(c.data))
    print(json.dumps({"path": str(out), "nodes": int(m.points.shape[0]), "cells": counts}))
    return 0
