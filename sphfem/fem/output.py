"""VTU time series of FEM substrate results (+ ParaView .pvd), written atomically."""

from __future__ import annotations

import base64
import sys
import zlib

import numpy as np

from sphfem.output import VTUSeries, atomic_write_bytes

#: meshio's block size of a compressed VTU data array [bytes]
_BLOCK = 32768


def encode_data_array(data: np.ndarray, compression: str | None, level: int | None) -> str:
    """The text of a binary VTU ``DataArray`` as meshio's writer makes it (header_type
    UInt32): zlib (``level``; None: zlib's default) in blocks of 32 KiB with meshio's block
    header, or raw (``compression`` None), base64-encoded."""
    data_bytes = np.ascontiguousarray(data).tobytes()
    if compression is None:
        header = np.array(len(data_bytes), dtype=np.uint32)
        return base64.b64encode(header.tobytes() + data_bytes).decode()
    lvl = -1 if level is None else int(level)
    view = memoryview(data_bytes)
    num_blocks = -int(-len(data_bytes) // _BLOCK)
    last_block_size = len(data_bytes) - (num_blocks - 1) * _BLOCK
    blocks = [zlib.compress(view[k * _BLOCK:(k + 1) * _BLOCK], lvl)
              for k in range(num_blocks)]
    header = np.array([num_blocks, _BLOCK, last_block_size] + [len(b) for b in blocks],
                      dtype=np.uint32)
    return base64.b64encode(header.tobytes()).decode() + base64.b64encode(
        b"".join(blocks)).decode()


class FEMSeries(VTUSeries):
    """One VTU per call of :meth:`write` plus ``<name>.pvd`` listing them by time.

    Point data (at mesh vertices): ``displacement`` (3 components, zero-padded in 2D),
    ``stress`` (9 components, row-major 3x3, L2-projected), ``von_mises``, ``dT``.
    Cell data: ``stress_elem`` (element average, 9 components) and ``von_mises_elem``.
    Each file goes to a temporary name and is renamed; the .pvd is rewritten atomically.

    With ``compression`` "zlib" or None the file is written here, not by meshio, with the
    same bytes as meshio's VTU writer (5.x: XML, binary data arrays, UInt32 headers) makes
    them: the mesh's points and cells, the same at every write, are encoded (compressed)
    once per mesh and their text reused; only the fields are encoded at each write.  Any
    other ``compression`` ("lzma") goes through meshio.

    ``layout = "appended"`` (an option; default "inline", the above): the arrays as raw
    binary in the file's ``<AppendedData encoding="raw">`` (UInt64 size headers), neither
    compressed nor base64-encoded, whatever ``compression``: the cheapest write (the
    droplet job's 36k-vertex substrate: ~1.6x the bytes of zlib level 1), the same arrays
    when read back (meshio, ParaView).
    """

    #: "inline" (meshio's layout, ``compression`` applies) or "appended" (raw binary)
    layout: str = "inline"

    def __init__(self, folder, name: str = "substrate"):
        super().__init__(folder, name)
        self.folder.mkdir(parents=True, exist_ok=True)
        self._static = None  # (key, text of the file's head up to the point data)
        self._static_raw = None  # (key, (the arrays of the mesh))

    def _meshio_mesh(self, result):
        from skfem.io.meshio import to_meshio

        mesh = result.substrate.mesh
        nv = mesh.nvertices
        u = np.zeros((nv, 3))
        u[:, : result.u.shape[1]] = result.u
        point_data = {
            "displacement": u,
            "stress": result.stress_nodes.reshape(nv, 9),
            "von_mises": result.von_mises_nodes,
            "dT": result.dT_nodes,
        }
        m = to_meshio(mesh, point_data=point_data, encode_cell_data=False)
        if m.points.shape[1] == 2:
            m.points = np.column_stack([m.points, np.zeros(len(m.points))])
        m.cell_data = {"stress_elem": [result.stress_elem.reshape(-1, 9)],
                       "von_mises_elem": [result.von_mises_elem]}
        return m

    def write(self, t: float, result):
        if self.layout not in ("inline", "appended"):
            raise ValueError(f"FEMSeries.layout must be 'inline' or 'appended', got "
                             f"{self.layout!r}")
        if sys.byteorder != "little" or (self.layout == "inline"
                                         and self.compression not in ("zlib", None)):
            return self.write_mesh(t, self._meshio_mesh(result))
        mesh = result.substrate.mesh
        nv = mesh.nvertices
        u = np.zeros((nv, 3))
        u[:, : result.u.shape[1]] = result.u
        point_data = (("displacement", u),
                      ("stress", result.stress_nodes.reshape(nv, 9)),
                      ("von_mises", result.von_mises_nodes),
                      ("dT", result.dT_nodes))
        cell_data = (("stress_elem", result.stress_elem.reshape(-1, 9)),
                     ("von_mises_elem", result.von_mises_elem))
        if self.layout == "appended":
            return self._write_appended(t, mesh, point_data, cell_data)
        level = self.compression_level if self.compression == "zlib" else None
        parts = [self._head(mesh, level), "<PointData>\n"]
        for name, a in point_data:
            parts.append(self._data_array(name, np.asarray(a), level))
        parts.append("</PointData>\n<CellData>\n")
        for name, a in cell_data:
            parts.append(self._data_array(name, np.asarray(a), level))
        parts.append("</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n")
        return self._write_text(t, "".join(parts))

    # -- the file's text ---------------------------------------------------------------
    def _data_array(self, name: str, data: np.ndarray, level) -> str:
        from meshio.vtu._vtu import numpy_to_vtu_type

        data = data.astype(data.dtype.newbyteorder("="), copy=False)
        attrs = f'type="{numpy_to_vtu_type[data.dtype]}" Name="{name}"'
        if data.ndim == 2:
            attrs += f' NumberOfComponents="{data.shape[1]}"'
        return (f'<DataArray {attrs} format="binary">\n'
                f"{encode_data_array(data, self.compression, level)}\n</DataArray>\n")

    def _mesh_arrays(self, mesh):
        """(points (n, 3), [(cell type, cells)], connectivity, offsets, types) of ``mesh``
        as meshio's VTU writer makes them."""
        from meshio._vtk_common import meshio_to_vtk_order, meshio_to_vtk_type
        from skfem.io.meshio import to_meshio

        m = to_meshio(mesh, encode_cell_data=False)
        points = m.points
        if points.shape[1] == 2:
            points = np.column_stack([points, np.zeros(len(points))])
        cells = [(c.type, c.data.astype(c.data.dtype.newbyteorder("="), copy=False))
                 for c in m.cells]
        connectivity = []
        for ctype, d in cells:
            order = meshio_to_vtk_order(ctype)
            connectivity.append((d[:, order] if order is not None else d).flatten())
        connectivity = np.concatenate(connectivity)
        offsets = [d.shape[1] * np.arange(1, d.shape[0] + 1, dtype=connectivity.dtype)
                   for _, d in cells]
        for k in range(1, len(offsets)):
            offsets[k] += offsets[k - 1][-1]
        offsets = np.concatenate(offsets)
        types = np.concatenate([np.full(len(d), meshio_to_vtk_type[ctype])
                                for ctype, d in cells])
        return points, cells, connectivity, offsets, types

    def _head(self, mesh, level) -> str:
        """The file's text up to the point data: declaration, VTKFile, comment, grid,
        piece, points and cells (meshio's layout), made once per mesh and settings."""
        key = (id(mesh), mesh.p.shape, mesh.t.shape, self.compression, level)
        if self._static is not None and self._static[0] == key:
            return self._static[1]
        from meshio.__about__ import __version__ as meshio_version

        points, cells, connectivity, offsets, types = self._mesh_arrays(mesh)
        vtk = ('<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian"'
               + (' compressor="vtkZLibDataCompressor"' if self.compression else "") + ">\n")
        text = ('<?xml version="1.0"?>\n' + vtk
                + f"<!--This file was created by meshio v{meshio_version}-->\n"
                + "<UnstructuredGrid>\n"
                + f'<Piece NumberOfPoints="{len(points)}" '
                  f'NumberOfCells="{sum(len(d) for _, d in cells)}">\n'
                + "<Points>\n" + self._data_array("Points", points, level) + "</Points>\n"
                + "<Cells>\n" + self._data_array("connectivity", connectivity, level)
                + self._data_array("offsets", offsets, level)
                + self._data_array("types", types, level) + "</Cells>\n")
        self._static = (key, text)
        return text

    def _write_appended(self, t: float, mesh, point_data, cell_data):
        """The file with every array as raw binary in ``<AppendedData>`` (``layout =
        "appended"``): each array a UInt64 byte count and its bytes, at the offset its
        DataArray names."""
        from meshio.vtu._vtu import numpy_to_vtu_type

        key = (id(mesh), mesh.p.shape, mesh.t.shape)
        if self._static_raw is None or self._static_raw[0] != key:
            self._static_raw = (key, self._mesh_arrays(mesh))
        points, cells, connectivity, offsets, types = self._static_raw[1]
        blobs: list = []
        pos = [0]

        def array(name, data):
            data = np.ascontiguousarray(data)
            attrs = f'type="{numpy_to_vtu_type[data.dtype]}" Name="{name}"'
            if data.ndim == 2:
                attrs += f' NumberOfComponents="{data.shape[1]}"'
            line = f'<DataArray {attrs} format="appended" offset="{pos[0]}"/>\n'
            blobs.append(np.array(data.nbytes, dtype="<u8").tobytes())
            blobs.append(memoryview(data).cast("B"))
            pos[0] += 8 + data.nbytes
            return line

        head = ['<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="0.1" '
                'byte_order="LittleEndian" header_type="UInt64">\n<UnstructuredGrid>\n'
                f'<Piece NumberOfPoints="{len(points)}" '
                f'NumberOfCells="{sum(len(d) for _, d in cells)}">\n<Points>\n',
                array("Points", points), "</Points>\n<Cells>\n",
                array("connectivity", connectivity), array("offsets", offsets),
                array("types", types), "</Cells>\n<PointData>\n"]
        head += [array(n, np.asarray(a)) for n, a in point_data]
        head.append("</PointData>\n<CellData>\n")
        head += [array(n, np.asarray(a)) for n, a in cell_data]
        head.append('</CellData>\n</Piece>\n</UnstructuredGrid>\n'
                    '<AppendedData encoding="raw">\n_')
        tail = b"\n</AppendedData>\n</VTKFile>\n"
        return self._write_text(t, "".join(head), blobs + [tail])

    def _write_text(self, t: float, text: str, binary=()):
        """``text`` (and the ``binary`` pieces after it) into the next file of the series
        (temporary name, renamed), then the .pvd (as :meth:`VTUSeries.write_mesh`)."""
        fname = f"{self.name}_{len(self.entries):05d}.vtu"
        atomic_write_bytes(self.folder / fname, [text.encode("ascii"), *binary])
        self.entries.append((float(t), fname))
        self._write_pvd()
        return self.folder / fname
