"""Memory of the fluid in a scene run (issue 19): per listed pair, one list and one work
buffer.

A scene whose only list user is the fluid gets the list built with the fluid's pair filter
(no unfiltered list, no filtered copy), and the fluid's compacted rows share the search's
work buffer (:func:`sphfem.neighbors.work_buffer`).  Before, the run held the unfiltered
list (4 B per listed pair), the fluid's filtered copy (4 B per kept pair) and a work buffer
of 1.25 x the unfiltered list (5 B), besides the search's own scratch: on this scene 12.0 B
per unfiltered pair, 19.8 B per kept pair (measured on 473bdbc).  Measured with
tracemalloc (numpy's allocations), so the figures do not depend on the allocator or on
other processes.
"""

import sys
import tracemalloc
from pathlib import Path

import numpy as np

from sphfem.particles import FLUID
from sphfem.scene import parse_scene
from sphfem.simulation import Simulation

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from memory import dambreak  # noqa: E402


def _per_particle_bytes(sim) -> int:
    """Bytes of the arrays with one row per particle: fields, the fluid's scratch, the
    positions at the last build and the list's offsets."""
    s = sim.modules[0].solver._scratch
    arrays = [*sim.particles.fields.values(), sim._x_at_build, sim.nbrs.offsets]
    arrays += [a for a in vars(s).values() if isinstance(a, np.ndarray)]
    return sum(a.nbytes for a in arrays)


def test_fluid_scene_holds_one_list_and_one_work_buffer(tmp_path):
    """3D dam break, fluid alone, 3 steps through ``Simulation.run``: what numpy holds
    beyond the per-particle arrays is at most 4 B (the list) + 4.5 B (one work buffer: the
    search's scratch or the 2 B compacted rows, with 1/8 headroom) + 1.5 B (small objects)
    per listed pair (measured 8.2), and the peak adds at most the output writer's copy of
    the fields on top; the old hand-over held 19.8 B per kept pair."""
    scene = parse_scene(dambreak(20_000), source="<memory test>")
    Simulation(scene)  # warm-up: numba kernels loaded, the work buffer allocated once
    from sphfem import neighbors

    neighbors._SCRATCH.work = None  # measured from scratch below
    tracemalloc.start()
    try:
        sim = Simulation(scene)
        sim.run(tmp_path / "out", progress=False)
        held, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    pairs = sim.nbrs.n_pairs
    n = sim.particles.n
    assert sim.step_count == 3 and np.count_nonzero(sim.particles.kind == FLUID) > 15_000
    per_pair = (held - _per_particle_bytes(sim)) / pairs
    assert per_pair < 4.0 + 4.5 + 1.5, per_pair
    # the list is the fluid's view: fluid rows keep fluid and wall neighbours, wall rows
    # their fluid neighbours only (wall-wall pairs are not listed)
    kind = sim.particles.kind
    rows = np.repeat(np.arange(n), np.diff(sim.nbrs.offsets))
    assert np.all(kind[sim.nbrs.indices][kind[rows] != FLUID] == FLUID)
    # the peak: the held memory plus transients no larger than the fields' size (the VTU
    # writer's float64 copy of every field, the first list's cell sort)
    fields = sum(a.nbytes for a in sim.particles.fields.values())
    assert peak - held < 1.5 * fields, (peak - held) / n
