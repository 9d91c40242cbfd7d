"""The coupling driver's history files (coupling.driver.CouplingDriver.write_history) made
from per-record texts cached between writes: the same bytes as serialising the whole
history at every write, across appended records, a restored (replaced) history, numpy
scalars and non-finite figures."""

import csv
import io
import json

import numpy as np

from coupling.driver import _COMPONENTS, CouplingDriver
from sphfem.output import _plain


def record(k: int, rng, probes: int) -> dict:
    rec = {"t": k * 1e-8, "step": np.int64(10 * k), "sensors": 40 + k,
           "force_sensors": rng.normal(size=2).tolist(),
           "peak_von_mises": float(rng.normal() * 1e7),
           "peak_location": [float(rng.random()), 0.0],
           "mean_stress": {c: float(rng.normal()) for c, _, _ in _COMPONENTS},
           "clipped_sensors": 0, "T_region_max": np.float64(300.0 + k)}
    if probes:
        rec["probes"] = [{**{c: float(rng.normal()) for c, _, _ in _COMPONENTS},
                          "von_mises": float(rng.random()), "T": 293.15 + k}
                         for _ in range(probes)]
    if k == 3:
        rec["force_residual_rel"] = float("nan")  # written as null
    return rec


def reference(drv) -> tuple[str, str]:
    """The files as the driver wrote them before: everything serialised at once."""
    js = json.dumps(_plain({"probes": None if drv.probes is None else drv.probes.tolist(),
                            "every_k_steps": drv.every_k, "history": drv.history}),
                    indent=2, allow_nan=False)
    buf = io.StringIO()
    w = csv.writer(buf)
    npb = 0 if drv.probes is None else len(drv.probes)
    head = ["t", "step", "peak_von_mises"] + [f"mean_s{c}" for c, _, _ in _COMPONENTS]
    for k in range(npb):
        head += [f"p{k}_s{c}" for c, _, _ in _COMPONENTS] + [f"p{k}_von_mises", f"p{k}_T"]
    w.writerow(head)
    for h in drv.history:
        row = [repr(h["t"]), h["step"], repr(h["peak_von_mises"])]
        row += [repr(h["mean_stress"][c]) for c, _, _ in _COMPONENTS]
        for p in h.get("probes", []):
            row += [repr(p[c]) for c, _, _ in _COMPONENTS] + [repr(p["von_mises"]), repr(p["T"])]
        w.writerow(row)
    return js, buf.getvalue()


def test_history_files_equal_whole_serialisation(tmp_path):
    rng = np.random.default_rng(3)
    for probes in (None, np.array([[0.0, -1e-6], [0.0, -5e-6]])):
        drv = CouplingDriver(None, None, probes=probes, every_k=13)
        npb = 0 if probes is None else len(probes)
        for stage in range(3):
            if stage == 2:  # a restored run: the history list replaced, one record fewer
                drv.history = [dict(h) for h in drv.history[:-1]]
            for _ in range(4):
                drv.history.append(record(len(drv.history), rng, npb))
                drv.write_history(tmp_path)
                js, text = reference(drv)
                assert (tmp_path / "history.json").read_bytes() == js.encode()
                assert (tmp_path / "probes.csv").read_bytes() == text.encode()
        json.loads(js)  # and it is JSON
    empty = CouplingDriver(None, None, every_k=None)
    assert empty.history_text() == reference(empty)[0]
