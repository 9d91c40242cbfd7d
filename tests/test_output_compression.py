"""VTU series compression (sphfem.output.VTUSeries): zlib at level 1 by default, raw or
another level on request; every variant reads back to the same arrays bit for bit, and
meshio's own zlib is put back after each write."""

import zlib

import meshio
import numpy as np

from sphfem.output import ParticleSeries


def test_vtu_compression_roundtrip(tmp_path):
    rng = np.random.default_rng(0)
    x = rng.normal(size=(2000, 2))
    T = np.round(rng.uniform(size=2000), 3)  # compressible: levels give different sizes
    mesh = meshio.Mesh(np.column_stack([x, np.zeros(len(x))]),
                       [("vertex", np.arange(len(x)).reshape(-1, 1))], point_data={"T": T})
    files = {}
    for name, comp, level in [("l1", "zlib", 1), ("l9", "zlib", 9), ("raw", None, 1)]:
        series = ParticleSeries(tmp_path / name)
        series.compression, series.compression_level = comp, level
        files[name] = series.write_mesh(0.0, mesh)
    from meshio.vtu import _vtu

    assert _vtu.zlib is zlib  # restored
    text = {k: f.read_text() for k, f in files.items()}
    assert 'compressor="vtkZLibDataCompressor"' in text["l1"] and "compressor" not in text["raw"]
    assert ParticleSeries.compression == "zlib" and ParticleSeries.compression_level == 1
    assert files["l9"].stat().st_size < files["l1"].stat().st_size < files["raw"].stat().st_size
    for f in files.values():
        m = meshio.read(f)
        assert np.array_equal(m.points[:, :2], x) and np.array_equal(m.point_data["T"], T)
