"""One toolpath optimisation job: what an evaluation needs, as a small picklable object.

:class:`ToolpathJob` holds the extrusion scene (its TOML text, parsed again on the worker),
the named case, nozzle and speed (from ``[extrusion]``), the fitness settings and the
evaluator (``[optimize]``).  Calling it with a parameter vector x builds the toolpath
(:mod:`sphfem.diw.toolpath`), deposits ink along it (:func:`sphfem.diw.extrusion.
simulate_deposit` or the lag model) and scores the deposit (:mod:`sphfem.diw.fitness`).
:meth:`ToolpathJob.describe` is everything a result depends on, hashed into the cache keys:
the optimiser's own settings (method, budget, population, seed) are not part of it, so the
methods share one cache.
"""

from __future__ import annotations

import functools
import tomllib
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from sphfem.diw.fitness import deposit_fitness
from sphfem.diw.toolpath import DesiredPath, ParameterSpace, Toolpath, named_case

__all__ = ["EvaluationFailed", "ToolpathJob", "load_job"]


class EvaluationFailed(RuntimeError):
    """An evaluation that produced no usable deposit (a guard stop of the simulation)."""


@dataclass(frozen=True)
class ToolpathJob:
    """Everything an evaluation depends on (module docstring)."""

    case: str
    speed: float
    nozzle_diameter: float
    h: float
    leg: float | None = None
    radius: float | None = None
    evaluator: str = "lag-model"
    gap_weight: float = 0.0
    objective: str = "thesis"
    centre_p: float = 8.0
    lag_time: float = 0.01
    lag_damping: float = 0.3
    lag_cost: float = 0.0
    scene_text: str | None = None
    source: str = "<job>"

    @functools.cached_property
    def _problem(self) -> tuple[DesiredPath, ParameterSpace]:
        return named_case(self.case, leg=self.leg, radius=self.radius)

    @property
    def desired(self) -> DesiredPath:
        return self._problem[0]

    @property
    def space(self) -> ParameterSpace:
        return self._problem[1]

    def describe(self) -> dict:
        """What a result depends on (hashed by :func:`sphfem.diw.evaluate.job_hash`)."""
        d = asdict(self)
        d.pop("source")
        d.pop("lag_cost")  # a sleep: changes the time an evaluation takes, not its result
        if d["objective"] != "centre":
            d.pop("centre_p")  # only the centre objective reads it
        if d["objective"] == "thesis":
            d.pop("objective")  # the default: the hashes of earlier jobs stay valid
        scene = d.pop("scene_text")
        if scene is not None:
            data = tomllib.loads(scene)
            data.pop("optimize", None)  # its evaluation keys are fields of the job
            d["scene"] = data
        if self.evaluator != "lag-model":
            for k in ("lag_time", "lag_damping"):
                d.pop(k)
        return d

    def toolpath(self, x=None) -> Toolpath:
        """The toolpath of parameters x (None: the naive toolpath, the desired path)."""
        if x is None:
            return Toolpath.naive(self.desired, self.speed)
        return Toolpath.from_parameters(self.desired, self.space, x, self.speed)

    def deposit(self, path: Toolpath, out_dir=None):
        """Ink deposited along ``path`` by the job's evaluator."""
        if self.evaluator == "lag-model":
            from sphfem.diw.lag_model import lag_deposit

            return lag_deposit(path, self.nozzle_diameter, self.h, self.lag_time,
                               self.lag_damping, cost_s=self.lag_cost)
        if self.evaluator == "extrusion":
            from sphfem.diw.extrusion import simulate_deposit
            from sphfem.scene import parse_scene_toml

            scene = parse_scene_toml(self.scene_text, source=self.source)
            return simulate_deposit(scene, path, out_dir=out_dir)
        raise ValueError(f"unknown evaluator {self.evaluator!r}")

    def evaluate(self, x=None, out_dir=None) -> tuple[dict, object]:
        """``(result, deposit)`` of parameters x: ``result`` has ``objective``, the fitness
        metrics and the run's ``info``; raises :class:`EvaluationFailed` on a guard stop."""
        dep = self.deposit(self.toolpath(x), out_dir=out_dir)
        info = dict(dep.info)
        if info.get("stopped_reason"):
            raise EvaluationFailed(f"simulation stopped: {info['stopped_reason']}")
        res = deposit_fitness(dep.positions, dep.h, dep.nozzle_diameter, self.desired,
                              gap_weight=self.gap_weight, objective=self.objective,
                              centre_p=self.centre_p)
        res["info"] = {k: v for k, v in info.items() if isinstance(v, (int, float, str))}
        if getattr(dep, "vtu", None):
            res["vtu"] = str(dep.vtu)
        return res, dep

    def __call__(self, x) -> dict:
        """The Dask task: the result of parameters x (no VTU written)."""
        return self.evaluate(np.asarray(x, dtype=float))[0]


def load_job(path, **overrides) -> tuple[ToolpathJob, object, object]:
    """``(job, optimize_record, scene)`` of an extrusion scene file with an optional
    ``[optimize]`` section; ``overrides`` replace ``[optimize]`` keys (None: keep)."""
    from sphfem.diw.optimize_section import OPTIMIZE
    from sphfem.errors import SceneError
    from sphfem.scene import load_scene
    from sphfem.schema.validate import Context, validate_section

    scene = load_scene(path)
    text = Path(path).read_text()
    data = tomllib.loads(text).get("optimize") or {}
    data.update({k: v for k, v in overrides.items() if v is not None})
    opt = validate_section(OPTIMIZE, data, Context(str(path)))
    ext = scene.sections.get("extrusion") if hasattr(scene, "sections") else None
    if ext is None:
        raise SceneError(str(path), "physics.modules",
                         'sphfem optimize needs an extrusion scene ("extrusion" in '
                         "[physics] modules, with its [extrusion] section)")
    job = ToolpathJob(
        case=ext.toolpath, speed=ext.nozzle_speed, nozzle_diameter=ext.nozzle_diameter,
        h=scene.sph.dx, leg=opt.leg, radius=opt.radius, evaluator=opt.evaluator,
        gap_weight=opt.gap_weight, objective=opt.objective, centre_p=opt.centre_p,
        lag_time=opt.lag_time,
        lag_damping=opt.lag_damping, lag_cost=opt.lag_cost, scene_text=text, source=str(path))
    try:
        job.space  # noqa: B018  (an unknown case name is a scene error)
    except ValueError as e:
        raise SceneError(str(path), "extrusion.toolpath", str(e)) from None
    return job, opt, scene
