"""The coupling's checkpoint holds its record lists as pickles made once per record
(coupling.driver.RecordPickles), not as a deep copy of the whole history at every
checkpoint: the restored records equal the live ones exactly, and the files written from
them are the same bytes."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from coupling.driver import PickledRecords, RecordPickles


def _records(n, start=0):
    return [{"t": 1e-7 * (start + k) / 3.0, "step": start + k,
             "probes": [{"xx": -1.5e6 * k, "T": 293.15 + k / 7.0}],
             "force_sensors": [0.1 * k, -2.0 / (k + 1)]} for k in range(n)]


def test_each_record_is_pickled_once():
    log = RecordPickles()
    hist = _records(3)
    a = log.snapshot(hist)
    assert len(a) == 3 and a.records() == hist
    hist += _records(2, start=3)
    b = log.snapshot(hist)
    assert b.records() == hist
    # the first three pickles are the ones of the first checkpoint (not made again)
    assert all(x is y for x, y in zip(a.blobs, b.blobs[:3], strict=True))
    # a checkpoint's copy does not move with the live list
    hist.append(_records(1, start=5)[0])
    assert len(b.records()) == 5
    # each pickle unpickles to a record equal to the live one, a new object
    for rec, got in zip(hist, b.records(), strict=False):
        assert got == rec and got is not rec


def test_a_replaced_list_is_pickled_again():
    log = RecordPickles()
    hist = _records(4)
    a = log.snapshot(hist)
    restored = a.records()  # as a resumed process holds it: equal records, new objects
    restored.append(_records(1, start=4)[0])
    b = log.snapshot(restored)
    assert b.records() == restored
    assert b.blobs[:4] == a.blobs[:4]  # the same bytes ...
    assert not any(x is y for x, y in zip(a.blobs, b.blobs[:4], strict=True))  # made anew
    # a list cut back (a record replaced in the middle) is pickled from there on
    restored[2] = {"t": 0.5, "step": 99}
    c = log.snapshot(restored)
    assert c.records() == restored
    assert all(x is y for x, y in zip(b.blobs[:2], c.blobs[:2], strict=True))


@pytest.fixture(scope="module")
def coupled_run(tmp_path_factory):
    """The droplet job (fluid, ring heat, fem-contact substrate heat, fem-axisymmetric
    stress) at D/dx 16 to 0.3 t_c."""
    from builders import coupled_droplet_run

    out = tmp_path_factory.mktemp("coupled")
    return coupled_droplet_run(out, 10, 16, 0.3), out


def test_coupling_state_restores_the_records_exactly(coupled_run, tmp_path):
    from sphfem.physics import snapshot_attrs

    sim, out = coupled_run
    mod = next(m for m in sim.modules if m.name == "coupling")
    drv, th = mod.driver, mod.driver.thermal
    assert len(drv.history) > 5 and len(th.history) > 5
    live = {"driver": drv.history, "thermal": th.history}
    # the deep copies the checkpoint held before (sphfem.physics.snapshot_attrs)
    old = {key: snapshot_attrs(obj, mod._STATE[key]) for key, obj in mod._stateful().items()}
    state = mod.checkpoint_state(sim.ctx)
    assert isinstance(state["driver"]["history"], PickledRecords)
    assert isinstance(state["thermal"]["history"], PickledRecords)
    assert [list(v) for v in state.values()] == [list(v) for v in old.values()]
    again = mod.checkpoint_state(sim.ctx)  # no record pickled twice
    assert all(x is y for x, y in zip(state["driver"]["history"].blobs,
                                      again["driver"]["history"].blobs, strict=True))
    # through the checkpoint file's pickle, as Simulation.load_checkpoint reads it
    state = pickle.loads(pickle.dumps(state, protocol=5))
    drv.write_history(tmp_path / "before")
    mod.restore_state(sim.ctx, state)
    for key, obj in (("driver", drv), ("thermal", th)):
        assert obj.history == old[key]["history"] == live[key]
        assert obj.history is not live[key]
        assert all(a is not b for a, b in zip(obj.history, live[key], strict=True))
    for key, obj in mod._stateful().items():
        for a in mod._STATE[key]:
            if a != "history":
                v, w = getattr(obj, a), old[key][a]
                same = (np.array_equal(v, w, equal_nan=True) if isinstance(v, np.ndarray)
                        else v == w)
                assert same, (key, a)
    # the history files written from the restored records are the same bytes
    drv.write_history(tmp_path / "after")
    for f in ("history.json", "probes.csv"):
        assert (tmp_path / "after" / f).read_bytes() == (tmp_path / "before" / f).read_bytes()
