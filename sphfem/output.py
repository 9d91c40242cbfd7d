"""Result files: atomic writes, output-folder guard, VTU/PVD particle series, summary.json.

Every file is first written to a temporary name in the same folder and then renamed, so a
killed run never leaves a half-written file behind.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
import zlib
from pathlib import Path

import numpy as np

from sphfem.errors import OutputExistsError  # noqa: F401  (defined there; re-exported here)


def file_mode() -> int:
    """Permissions of a new file as ``open()`` makes it: 0o666 minus the process umask.

    ``tempfile.mkstemp`` creates its files 0o600 whatever the umask, so a result written
    through it would be readable by its owner only; :func:`atomic_write_bytes` gives the
    file this mode instead.  The umask is read from ``/proc/self/status`` (Linux >= 4.7)
    or, elsewhere, by setting it and putting it back.
    """
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return 0o666 & ~int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


def atomic_write_bytes(path, data) -> None:
    """Write ``data`` (bytes, or a sequence of bytes pieces written one after the other)
    to ``path`` via a temporary file and an atomic rename (mode :func:`file_mode`, as a
    plain ``open()`` would make it)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        if hasattr(os, "fchmod"):
            os.fchmod(fd, file_mode())
        with os.fdopen(fd, "wb") as fh:
            for piece in ((data,) if isinstance(data, (bytes, bytearray, memoryview))
                          else data):
                fh.write(piece)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write_text(path, text: str) -> None:
    """Text variant of :func:`atomic_write_bytes` (UTF-8)."""
    atomic_write_bytes(path, text.encode("utf-8"))


def write_json(path, obj) -> None:
    """Atomically write ``obj`` as indented JSON (numpy scalars/arrays converted)."""
    atomic_write_text(path, json.dumps(_plain(obj), indent=2, allow_nan=False))


def _plain(o):
    """Convert numpy types, tuples and non-finite floats into JSON-safe values."""
    if isinstance(o, dict):
        return {str(k): _plain(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_plain(v) for v in o]
    if isinstance(o, np.ndarray):
        return _plain(o.tolist())
    if isinstance(o, np.generic):
        return _plain(o.item())
    if isinstance(o, float) and not np.isfinite(o):
        return None
    if isinstance(o, Path):
        return str(o)
    return o


def prepare_output_dir(path, overwrite: bool = False, resume: bool = False,
                       check_only: bool = False) -> Path:
    """Create the output folder; refuse an existing non-empty one unless told otherwise.

    ``overwrite`` deletes the old contents; ``resume`` keeps them (for a checkpoint restart).
    ``check_only`` raises the same errors but neither deletes nor creates anything.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputExistsError(f"{path}: exists and is not a folder")
    if path.exists() and any(path.iterdir()):
        if resume:
            return path
        if not overwrite:
            raise OutputExistsError(
                f"{path}: output folder exists and is not empty; pass --overwrite to replace it"
            )
        if check_only:
            return path
        shutil.rmtree(path)
    if check_only:
        return path
    path.mkdir(parents=True, exist_ok=True)
    return path


class _ZlibAtLevel:
    """zlib with a fixed compression level (what meshio's VTU writer calls)."""

    def __init__(self, level: int):
        self.level = int(level)

    def compress(self, data):
        return zlib.compress(data, self.level)

    def __getattr__(self, name):
        return getattr(zlib, name)


@contextlib.contextmanager
def _zlib_level(level):
    """Within the block meshio's VTU writer compresses at zlib ``level`` (None: its own):
    its module-level ``zlib`` is swapped for a :class:`_ZlibAtLevel` (only if meshio has
    one; otherwise nothing changes)."""
    try:
        from meshio.vtu import _vtu
    except ImportError:  # pragma: no cover - another meshio layout
        _vtu = None
    if level is None or _vtu is None or getattr(_vtu, "zlib", None) is not zlib:
        yield
        return
    _vtu.zlib = _ZlibAtLevel(level)
    try:
        yield
    finally:
        _vtu.zlib = zlib


def pvd_frames(pvd) -> list[tuple[float, Path]]:
    """``[(t, path of the VTU), ...]`` listed by a ParaView ``.pvd`` collection (as
    :class:`VTUSeries` writes it), in the file's order."""
    import xml.etree.ElementTree as ET

    pvd = Path(pvd)
    root = ET.parse(pvd).getroot()
    return [(float(d.get("timestep")), pvd.parent / d.get("file"))
            for d in root.iter("DataSet")]


class VTUSeries:
    """A VTU file per output time plus a ParaView ``.pvd`` collection listing them by time.

    :meth:`write_mesh` writes a meshio mesh to a temporary name, renames it, and rewrites
    the ``.pvd`` atomically; subclasses build the mesh of what they store.

    ``compression``: the VTU block compressor (meshio: ``None``, ``"zlib"`` or ``"lzma"``)
    and ``compression_level`` the zlib level (default 1).  meshio compresses with zlib's
    default level 6; level 1 took 0.20 against 0.46 CPU-s for a 72k-node substrate mesh of
    the axisymmetric droplet job (8.76 against 8.51 MB; raw: 0.06 s, 18.0 MB), whose
    coupling writes that mesh every 4 coupling steps.  Set them on a series (or the class).
    """

    #: meshio's VTU compressor: "zlib" (default), "lzma" or None (raw binary)
    compression: str | None = "zlib"
    #: zlib level of ``compression = "zlib"`` (1 fastest ... 9 smallest; meshio's own: 6)
    compression_level: int = 1

    def __init__(self, folder, name: str):
        self.folder = Path(folder)
        self.name = name
        self.entries: list[tuple[float, str]] = []

    def write_mesh(self, t: float, mesh) -> Path:
        import meshio

        self.folder.mkdir(parents=True, exist_ok=True)
        fname = f"{self.name}_{len(self.entries):05d}.vtu"
        tmp = self.folder / f".{fname}.tmp.vtu"
        try:
            with _zlib_level(self.compression_level if self.compression == "zlib" else None):
                meshio.write(tmp, mesh, file_format="vtu", compression=self.compression)
            os.replace(tmp, self.folder / fname)
        finally:
            if tmp.exists():
                tmp.unlink()
        self.entries.append((float(t), fname))
        self._write_pvd()
        return self.folder / fname

    def _write_pvd(self) -> None:
        rows = "\n".join(
            f'    <DataSet timestep="{t:.9g}" group="" part="0" file="{f}"/>'
            for t, f in self.entries
        )
        text = (
            '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
            f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n"
        )
        atomic_write_text(self.folder / f"{self.name}.pvd", text)


class ParticleSeries(VTUSeries):
    """Particles as VTK vertex cells with their fields as point data (through meshio)."""

    def __init__(self, folder, name: str = "particles"):
        super().__init__(folder, name)

    def write(self, t: float, particles, fields=None) -> Path:
        import meshio

        x = particles.x
        n, dim = x.shape
        pts = np.zeros((n, 3))
        pts[:, :dim] = x
        data = {}
        for k in fields or particles.fields:
            if k == "x" or k not in particles.fields:
                continue
            a = particles.fields[k]
            if a.ndim == 2 and a.shape[1] == dim and dim < 3:
                b = np.zeros((n, 3), dtype=np.float64)
                b[:, :dim] = a
                a = b
            elif a.ndim == 3:
                a = a.reshape(n, -1)
            data[k] = a.astype(np.float64) if a.dtype.kind in "biu" else a
        mesh = meshio.Mesh(pts, [("vertex", np.arange(n).reshape(-1, 1))], point_data=data)
        return self.write_mesh(t, mesh)
