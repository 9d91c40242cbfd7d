"""The ``[optimize]`` scene section: how ``sphfem optimize`` searches the toolpath of an
extrusion scene (pure declarations; read by :mod:`sphfem.diw.job` only, ignored by
``sphfem run``).  The path, nozzle and speed come from ``[extrusion]``."""

from __future__ import annotations

from sphfem.schema import Param, Section, register_section

OPTIMIZE = register_section(Section("optimize", (
    Param("method", str, "pso", choices=("pso", "cma", "de"),
          doc="optimiser: the thesis' particle swarm with re-seeding (algorithm 3.4), "
              "CMA-ES or differential evolution (pymoo; `--method` overrides)"),
    Param("budget", int, 200, ge=1,
          doc="evaluations (simulations) of the optimisation, rounded up to whole "
              "iterations of `population`; a budget below `population` is one iteration "
              "of `budget` members (`--budget` overrides)"),
    Param("population", int, 20, ge=2, doc="members per iteration (swarm size)"),
    Param("seed", int, 0, ge=0, doc="random seed of the optimiser (a resumed run retraces "
                                    "the interrupted one with it)"),
    Param("start_naive", bool, True,
          doc="make the naive toolpath (all delta = 0) a member of the first population, "
              "so the result is never worse than it (false: the thesis' all-random start)"),
    Param("inertia", float, 0.7298, ge=0.0, doc="PSO inertia weight w"),
    Param("c1", float, 1.49618, ge=0.0, doc="PSO cognitive coefficient C1 (personal best)"),
    Param("c2", float, 1.49618, ge=0.0, doc="PSO social coefficient C2 (global best)"),
    Param("reseed", int, None, ge=0, default_doc="population // 10 (at least 1)",
          doc="PSO: members with the poorest fitness re-seeded at random each iteration (M)"),
    Param("objective", str, "thesis", choices=("thesis", "edge", "centre"),
          doc="what is minimised: thesis = sum (dist/h)^3 over the deposit (eq. 3.47; dist "
              "includes the bead's half-width); edge = the same form over the distances "
              "beyond the desired bead of the deposit's own width (particles outside its "
              "edges, points of its edges and centreline left uncovered); centre = the "
              "power mean (1/N sum_k (c_k/h)^p)^(1/p) of the bead's centreline offsets c_k "
              "in stations one D long, a smooth stand-in for their maximum "
              "(sphfem.diw.fitness)"),
    Param("centre_p", float, 8.0, ge=1.0,
          doc="exponent p of the centre objective's power mean: 1 = the mean centreline "
              "offset, larger p -> its maximum over the stations"),
    Param("gap_weight", float, 0.0, ge=0.0,
          doc="objective = thesis or edge + gap_weight sum (gap/h)^3 over the stretches "
              "of the path the bead leaves uncovered (0: none)"),
    Param("leg", float, None, unit="m", positive=True, quantity="length",
          default_doc="5 mm", doc="length of the straight legs of the named toolpath case"),
    Param("radius", float, None, unit="m", positive=True, quantity="length",
          default_doc="2 mm (bend180-small), 5 mm (bend180-large)",
          doc="radius of the half circle of the 180-degree bends"),
    Param("evaluator", str, "extrusion", choices=("extrusion", "lag-model"),
          doc="what evaluates a toolpath: the SPH extrusion (sphfem.diw.extrusion) or the "
              "analytic lag model (sphfem.diw.lag_model: a stand-in for tests and "
              "throughput measurements)"),
    Param("lag_time", float, 0.01, unit="s", positive=True, quantity="time",
          doc="lag model: relaxation time tau of the deposit behind the nozzle"),
    Param("lag_damping", float, 0.3, positive=True,
          doc="lag model: damping ratio zeta (< 1 overshoots corners)"),
    Param("lag_cost", float, 0.0, unit="s", ge=0.0, quantity="time",
          doc="lag model: fixed sleep added to each evaluation (a known cost for "
              "throughput measurements)"),
), doc=(
    "Toolpath optimisation of an extrusion scene (issue 18, thesis sec. 3.3): read by "
    "`sphfem optimize` only. The parameters are the free waypoints (s_i, delta_i) of the "
    "named case in `[extrusion] toolpath` (thesis tables 3.3-3.5, sphfem.diw.toolpath); "
    "every evaluation is a Dask task cached on disk under `--out`.")))
