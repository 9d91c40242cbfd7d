"""Watch for a collapsing time step: a run that crawls should say so and why.

A run's stable step can fall by orders of magnitude for reasons that have nothing to do
with the answer -- in the axisymmetric droplet impact a few spray rings far above the film
collide near the axis, reach twice the reference density and ~1000 m/s, and the acoustic
limit of the whole run falls tenfold (docs/validation/spreading_axisymmetric, session 24):
the run then looks stalled for hours with nothing shown (by default a fivefold drop
that lasts 200 steps is reported).  :class:`StepCollapseWatch`
compares each step's stable limit with a slow running reference (the exponential moving
average of log dt over ``memory`` steps, frozen while the step is collapsed) and reports
a collapse when the limit stays below ``factor`` times the reference for ``steps``
consecutive steps: once per episode, with the
time, the step, the reference and the limit that set it.  The driver logs it as a warning
and lists the episodes in ``summary.json`` (``dt.collapses``).
"""

from __future__ import annotations

import math


class StepCollapseWatch:
    """Detector of collapsed time steps (module docstring).

    ``factor``: a step below ``factor`` x the reference counts as collapsed; ``steps``:
    consecutive collapsed steps that make an episode; ``memory``: the reference's averaging
    length in steps."""

    def __init__(self, factor: float = 0.2, steps: int = 200, memory: int = 2000):
        if not 0.0 < factor < 1.0:
            raise ValueError(f"StepCollapseWatch: factor must lie in (0, 1), got {factor!r}")
        if steps < 1 or memory < 1:
            raise ValueError("StepCollapseWatch: steps and memory must be >= 1")
        self.factor, self.steps, self.memory = float(factor), int(steps), int(memory)
        self.log_ref: float | None = None
        self.run = 0            # consecutive collapsed steps (> steps: inside an episode)
        self.run_min = math.inf  # the smallest of them
        self.episodes: list[dict] = []

    def observe(self, t: float, dt: float, limiter: str) -> dict | None:
        """Take one step's stable limit ``dt`` [s] (set by ``limiter``) at time ``t``;
        returns the episode's record when a collapse has just lasted ``steps`` steps, else
        None.  The record's ``steps`` and ``min_dt`` keep growing while it lasts."""
        if not (dt > 0.0 and math.isfinite(dt)):
            return None
        lg = math.log(dt)
        if self.log_ref is None:
            self.log_ref = lg
        ref = math.exp(self.log_ref)
        new = None
        if dt < self.factor * ref:
            self.run += 1
            self.run_min = min(self.run_min, float(dt))
            if self.run == self.steps:
                new = {"t": float(t), "dt": float(dt), "reference_dt": ref,
                       "limiter": str(limiter), "steps": self.run, "min_dt": self.run_min}
                self.episodes.append(new)
            elif self.run > self.steps:
                ep = self.episodes[-1]
                ep["steps"], ep["min_dt"] = self.run, self.run_min
        else:  # the reference follows the steps that are not collapsed only
            self.run, self.run_min = 0, math.inf
            self.log_ref += (lg - self.log_ref) / self.memory
        return new
