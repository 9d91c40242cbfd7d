"""The library facade: run a scene, read its results, run a validation case.

``import sphfem`` exposes these names lazily (nothing numba-heavy is imported until one is
used); docs/api.md shows each in a runnable example::

    scene = sphfem.load_scene("drop.toml")          # a path, a dict or a Scene
    res = sphfem.run(scene, out="runs/drop", overwrite=True)
    res.summary["steps"], res.particles.T, res.peak_von_mises, res.probes(), res.history()

    r = sphfem.validate("laplacian", quick=True, json="lap.json", plot="lap.png")
    r.passed, r.runs, sphfem.validation.format_table(r)

The substrate solvers are the classes themselves (:class:`sphfem.fem.FEMSubstrate`,
:class:`sphfem.solid.backend.TLSPHSubstrate`), re-exported as ``sphfem.FEMSubstrate`` and
``sphfem.TLSPHSubstrate`` together with the mesh recipes ``substrate_rect`` /
``substrate_block`` and ``load_mesh``.

The command line is built on this module: ``sphfem run`` calls :func:`run` (the same scene
validation, output-folder guard, set-up, driver and ``summary.json``) and only adds its own
wording and exit codes.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path

from sphfem.errors import OutputExistsError, OutputFolderError, SceneError

logger = logging.getLogger(__name__)

__all__ = ["OutputFolderError", "Result", "RunStopped", "SceneError", "load_result",
           "load_scene", "run", "validate", "validation_cases"]


# --------------------------------------------------------------------------------------
# scenes and runs


def load_scene(scene, source: str | None = None):
    """A validated :class:`sphfem.scene.Scene` from a TOML file path, a scene dict (as
    ``tomllib`` or ``Scene.to_dict()`` give it) or a Scene (returned as is).

    ``source`` names a dict's origin in error messages; a relative ``coupling.mesh_file``
    is resolved against the folder of a file ``source`` (default: the working folder).
    Mistakes raise :class:`sphfem.scene.SceneError` (one line: ``source: key: message``).
    """
    from sphfem.scene import Scene, parse_scene
    from sphfem.scene import load_scene as _load

    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, dict):
        return parse_scene(scene, source=source or "<dict>")
    if isinstance(scene, (str, os.PathLike)):
        return _load(scene)
    raise TypeError(f"scene: expected a path, a dict or a Scene, got {type(scene).__name__}")


class RunStopped(Exception):
    """A stability guard stopped the run; ``.result`` holds what was written (status
    ``"stopped"``, the last finite state, ``summary.json``)."""

    def __init__(self, message: str, result: Result):
        super().__init__(message)
        self.result = result


def run(scene, out, overwrite: bool = False, resume: bool = False, progress: bool = False,
        raise_on_stop: bool = True, keep_checkpoint: bool = False) -> Result:
    """Run ``scene`` (path, dict or Scene) to its end time, writing into folder ``out``.

    ``sphfem run SCENE --out OUT`` is this function, returned as a :class:`Result` that
    keeps the live simulation (final particle state) next to ``summary.json`` and the output
    files.  An existing non-empty ``out`` raises :class:`sphfem.output.OutputExistsError`
    unless ``overwrite`` (delete it first) or ``resume`` (continue from its checkpoint, which
    a completed run deletes unless ``keep_checkpoint``); a folder that cannot be created
    raises :class:`sphfem.errors.OutputFolderError`; both are checked before the set-up.  A
    set-up that fails on the scene's inputs (a mesh file missing or corrupt, an unknown mesh
    group, overlapping blocks) raises :class:`sphfem.scene.SceneError` (``source: set-up
    failed: ...``, the original error chained) before anything is written.  ``progress``:
    the progress bar and the set-up stage lines on stderr (:mod:`sphfem.progress`).  A run
    stopped by a stability guard raises :class:`RunStopped` (``raise_on_stop=False``:
    returns the result with ``status == "stopped"``).
    """
    from sphfem import progress as report
    from sphfem.output import prepare_output_dir
    from sphfem.simulation import SimulationStopped

    sc = load_scene(scene)
    source = str(scene) if isinstance(scene, (str, os.PathLike)) else getattr(sc, "source", None)
    opts = dict(overwrite=overwrite, resume=resume)
    try:  # refuse before the (possibly long) set-up
        prepare_output_dir(out, check_only=True, **opts)
    except OutputExistsError as e:
        raise OutputExistsError(str(e).replace("--overwrite", "overwrite=True")) from None
    _check_creatable(out)
    was = report.enabled()
    report.enable(progress or was)
    try:
        sim = _set_up(sc, source)
        try:
            folder = prepare_output_dir(out, **opts)
        except OSError as e:
            raise OutputFolderError(f"{out}: cannot create the output folder: "
                                    f"{e.strerror or e}") from e
        try:
            summary = sim.run(folder, progress=progress, resume=resume,
                              keep_checkpoint=keep_checkpoint)
        except SimulationStopped as e:
            res = Result(folder, load_result(folder).summary, sc, sim)
            if raise_on_stop:
                raise RunStopped(str(e), res) from None
            return res
    finally:
        report.enable(was)
    return Result(folder, summary, sc, sim)


def _check_creatable(out) -> None:
    """Raise :class:`OutputFolderError` unless ``out`` exists or its nearest existing
    ancestor is a writable folder (checked before the set-up, which can take minutes)."""
    if os.path.exists(out):
        return
    up = os.path.dirname(os.path.abspath(out))
    while not os.path.exists(up):
        up = os.path.dirname(up)
    if not os.path.isdir(up) or not os.access(up, os.W_OK | os.X_OK):
        why = "is not a folder" if not os.path.isdir(up) else "is not writable"
        raise OutputFolderError(f"{out}: cannot create the output folder: {up} {why}")


def _set_up(scene, source):
    """Build the :class:`sphfem.simulation.Simulation` of ``scene``; a failure on the
    scene's inputs (meshes, probes, particles) becomes a :class:`SceneError` naming
    ``source``."""
    from sphfem.simulation import Simulation

    try:
        return Simulation(scene, source=source)
    except SceneError:  # e.g. overlapping blocks, found while building particles
        raise
    except (ValueError, KeyError, OSError) as e:
        msg = " ".join(str(e).split()) or type(e).__name__
        raise SceneError(source or scene.source, "", f"set-up failed: {msg}") from e


def load_result(out) -> Result:
    """The :class:`Result` of a finished run read back from its folder (no live particles:
    read the fields of an output frame with :meth:`Result.frame`)."""
    import json

    out = Path(out)
    path = out / "summary.json"
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no summary.json (not a finished run's folder)")
    summary = json.loads(path.read_text())
    scene = None
    if summary.get("scene") is not None:
        try:
            scene = load_scene(summary["scene"], source=summary.get("scene_file") or str(path))
        except ValueError as e:  # a scene of an older version: keep the summary usable
            logger.warning("%s: the recorded scene does not validate (%s)", path, e)
    return Result(out, summary, scene, None)


@dataclass
class Result:
    """A run: its output folder, ``summary.json`` (as a dict), the scene and, for a run
    made by :func:`run` in this process, the live :class:`sphfem.simulation.Simulation`.

    Files in ``out``: ``summary.json``; ``particles.pvd`` + ``particles_NNNNN.vtu`` (one
    per output time, :meth:`frames`); with a coupled substrate ``<coupling.output>/``
    (default ``substrate/``) holds ``probes.csv`` (:meth:`probes`), ``history.json``
    (:meth:`history`) and ``substrate.pvd`` (``frames("substrate")``).
    """

    out: Path
    summary: dict
    scene: object = None
    simulation: object = None

    # -- summary figures ------------------------------------------------------------------
    @property
    def status(self) -> str:
        """``"completed"``, ``"max_steps"`` or ``"stopped"``."""
        return self.summary["status"]

    @property
    def ok(self) -> bool:
        return self.status != "stopped"

    @property
    def diagnostics(self) -> dict:
        """Each physics module's diagnostics, by module name."""
        return self.summary.get("diagnostics", {})

    @property
    def coupling(self) -> dict | None:
        """The coupling's diagnostics (solves, peak von Mises, heat ledger, backend), or
        None when the scene has no coupled substrate."""
        return self.diagnostics.get("coupling")

    @property
    def peak_von_mises(self) -> dict | None:
        """``{"value": Pa, "location": [m], "t": s}`` over every substrate solve, or None."""
        c = self.coupling
        if c is None or c.get("peak_von_mises_Pa") is None:
            return None
        return {"value": c["peak_von_mises_Pa"], "location": c["peak_von_mises_location_m"],
                "t": c["peak_von_mises_t_s"]}

    # -- particles ------------------------------------------------------------------------
    @property
    def particles(self):
        """The final particle state (:class:`sphfem.particles.ParticleSet`: ``x``, ``v``,
        ``T``, ``m``, ``kind``, ``material``, ...).  Particles are sorted by cell during
        the run; the field ``id`` is each particle's index at build time."""
        if self.simulation is None:
            raise AttributeError("this Result was read from disk: use frame(-1) for the "
                                 "last written particle fields")
        return self.simulation.particles

    def mask(self, kind: str | None = None, material: str | None = None):
        """Boolean mask of the final particles of ``kind`` ("fluid", "wall", "solid",
        "ghost") and/or ``material`` (a name in ``[materials]``)."""
        import numpy as np

        from sphfem.particles import KIND_NAMES

        ps = self.particles
        m = np.ones(ps.n, bool)
        if kind is not None:
            m &= ps.kind == KIND_NAMES[kind]
        if material is not None:
            m &= ps.material == self.scene.material_index(material)
        return m

    def frames(self, series: str = "particles") -> list[tuple[float, Path]]:
        """``[(t, path), ...]`` of a VTU series from its ``.pvd`` (``"particles"``, or
        ``"substrate"`` for the FEM substrate's series)."""
        pvd = self.out / f"{series}.pvd"
        if not pvd.is_file() and self.coupling is not None:
            pvd = self.out / self._coupling_folder() / f"{series}.pvd"
        if not pvd.is_file():
            raise FileNotFoundError(f"{pvd}: no such series")
        from sphfem.output import pvd_frames

        return pvd_frames(pvd)

    def frame(self, k: int = -1, series: str = "particles") -> dict:
        """Frame ``k`` of a series as ``{"t": s, "x": (n, dim) points, field: array}``
        (VTU point data; 2D vectors padded to 3 components are cut back to 2)."""
        import meshio

        t, path = self.frames(series)[k]
        m = meshio.read(path)
        dim = self.scene.dim if self.scene is not None else 3
        out = {"t": t, "x": m.points[:, :dim]}
        for name, a in m.point_data.items():
            out[name] = a[:, :dim] if a.ndim == 2 and a.shape[1] == 3 and dim < 3 else a
        return out

    # -- substrate ------------------------------------------------------------------------
    def _coupling_folder(self) -> str:
        sc = self.scene
        cfg = getattr(sc, "coupling", None) if sc is not None else None
        return cfg.output if cfg is not None else "substrate"

    def probes(self) -> dict | None:
        """The substrate's history, one entry per solve, from ``probes.csv``: arrays ``t``,
        ``peak_von_mises``, ``mean_s{xx,yy,zz,xy,yz,xz}`` and per probe point k
        ``p{k}_s..``, ``p{k}_von_mises``, ``p{k}_T``; ``points`` (n, dim) [m].  None
        without a coupled substrate."""
        import csv

        import numpy as np

        if self.coupling is None:
            return None
        path = self.out / self._coupling_folder() / "probes.csv"
        with open(path, newline="") as fh:
            rows = list(csv.reader(fh))
        head, data = rows[0], np.array(rows[1:], dtype=float).reshape(-1, len(rows[0]))
        out = {h: data[:, i] for i, h in enumerate(head)}
        out["step"] = out["step"].astype(int)
        pts = self.coupling.get("probes_m")
        out["points"] = None if pts is None else np.asarray(pts, float)
        return out

    def history(self) -> list[dict] | None:
        """One record per substrate solve from ``history.json``: ``t``, ``step``,
        ``force_sensors`` / ``force_load`` (total force the fluid exerts on the substrate
        before / after the transfer [N, in 2D N/m]), ``peak_von_mises``,
        ``peak_location``, ``mean_stress`` and ``probes``.  None without a coupled
        substrate."""
        import json

        if self.coupling is None:
            return None
        path = self.out / self._coupling_folder() / "history.json"
        return json.loads(path.read_text())["history"]

    def __repr__(self) -> str:
        s = self.summary
        t = s.get("t")
        return (f"Result(out={str(self.out)!r}, status={s.get('status')!r}, "
                f"steps={s.get('steps')}, t={t if t is None else f'{t:.4g}'})")


# --------------------------------------------------------------------------------------
# validation


def validation_cases() -> dict[str, str]:
    """Name -> description (first paragraph of its docstring) of every validation case."""
    from sphfem.validation import load_cases

    return {name: " ".join((fn.__doc__ or "").strip().split("\n\n")[0].split())
            for name, fn in sorted(load_cases().items())}


def validate(case: str, quick: bool = False, json=None, plot=None, warmup: bool = True):
    """Run validation case ``case`` and return its :class:`sphfem.validation.CaseResult`
    (``.runs``: variant, resolution, particles, relative L2 / L-inf error, wall seconds;
    ``.criteria``; ``.observed_order``; ``.passed``; ``.to_json()``); the printed table is
    ``sphfem.validation.format_table(result)``.  ``json`` / ``plot``: also write the JSON
    and the work-precision PNG (error against wall seconds) there.  ``warmup``: an untimed
    first pass moves numba's compilation out of the timed runs
    (:func:`sphfem.validation.run_case`), as ``sphfem validate`` does."""
    from sphfem.validation import load_cases, run_case, work_precision_plot, write_json

    cases = load_cases()
    if case not in cases:
        raise ValueError(f"unknown validation case {case!r}; known: {', '.join(sorted(cases))}")
    result = run_case(case, quick, warmup=warmup)
    if json is not None:
        write_json(result, json)
    if plot is not None:
        work_precision_plot(result, plot)
    return result
