"""Wetting criterion of the contact-heat interface (coupling.heat_interface, eq. 2 and
"Wetting" there): the contact layer does not depend on the height at which the fluid
rides in its first cell above the wall, and the ideal contact heat accumulated over the
wetted-node history of a prescribed spreading disc converges to the ideal contact heat
over the disc's true radius history r(t), in planar, axisymmetric (ring weights) and 3D
geometry."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from coupling.heat_interface import ContactHeatInterface, step_mean_inv_sqrt
from sphfem.fem.heat_transient import TransientHeat, graded_mesh

WATER = (0.6, 1000.0, 4000.0)
ALUMINA = (10.0, 3950.0, 900.0)
TF, TS = 373.15, 293.15
EF, ES = (math.sqrt(k * r * c) for k, r, c in (WATER, ALUMINA))
#: ideal contact: heat per area 2 C sqrt(t) (Carslaw & Jaeger 1959, sec. 2.15)
C = EF * ES * (TF - TS) / ((EF + ES) * math.sqrt(math.pi))


def _surface(geom, width, h_lat, span=None):
    """A shallow FEM heat substrate under the plane z = 0 (only its surface matters):
    [0, width] (x [0, span] in 3D, default width)."""
    axi = geom == "axisymmetric"
    lateral = [(0.0, width)] + ([(0.0, span or width)] if geom == "3d" else [])
    mesh = graded_mesh(lateral, 4.0 * h_lat, 0.5 * h_lat, 2.0,
                       h_lateral=h_lat, axisymmetric=axi)
    return TransientHeat(mesh, *ALUMINA, TS, axisymmetric=axi)


def _layers(geom, dx, edge, width, n_layers, gap, jitter=(0.0, 0.0), seed=3, span=None):
    """Lattice cells of side dx whose centres lie inside the fluid's contact region
    (x < edge: a strip over the full span in 3D, a disc r < edge in the axisymmetric
    case), ``n_layers`` high, the first layer's lower face ``gap`` above the wall;
    ``jitter`` (lateral, vertical) uniform displacements of each cell in units of dx (the
    same for a cell whatever ``edge``).  Returns positions, volumes (ring volumes
    2 pi r dx^2 when axisymmetric) and each cell's layer index."""
    dim = 3 if geom == "3d" else 2
    nx = int(round(width / dx)) + 1
    ny = int(round((span or width) / dx)) if dim == 3 else 1
    g = np.meshgrid(*[(np.arange(m) + 0.5) * dx for m in (nx, ny)][:dim - 1],
                    (np.arange(n_layers) + 0.5) * dx + gap, indexing="ij")
    x = np.column_stack([a.ravel() for a in g])
    layer = np.rint((x[:, -1] - gap) / dx - 0.5).astype(int)
    rng = np.random.default_rng(seed)
    x[:, :-1] += jitter[0] * dx * rng.uniform(-1, 1, (len(x), dim - 1))
    x[:, -1] += jitter[1] * dx * rng.uniform(-1, 1, len(x))
    x[:, 0] = np.abs(x[:, 0])
    x, layer = x[x[:, 0] < edge], layer[x[:, 0] < edge]
    vol = dx**dim * (2 * np.pi * x[:, 0] if geom == "axisymmetric" else 1.0)
    return x, vol, layer


def _area(geom, edge, width):
    return {"planar": edge, "axisymmetric": math.pi * edge**2, "3d": edge * width}[geom]


@pytest.mark.parametrize("geom", ["planar", "axisymmetric", "3d"])
def test_wetted_area_independent_of_ride_height(geom):
    """Three jittered layers of fluid cells (lateral +-0.15 dx, vertical +-0.1 dx) over
    part of the wall, the first layer's lower face riding 0.1 ... 0.85 dx above it: the
    wetted nodes, the sampled cells and their weights, and the exchange conductance are
    the same at every height; only first-layer cells are sampled (the second layer, whose
    lower face comes within one cell of the wall when the first rides low, lies over the
    first and is left out); the wetted area is the fluid's footprint to within one
    lateral surface cell along the contact line.  The earlier criterion (chi(z/h), eq. 2
    before) wetted nothing once the layer's centre rode above 0.75 dx."""
    dx = 1e-6
    width, h_lat = 12 * dx, 0.5 * dx
    edge = 7.3 * dx
    sub = _surface(geom, width, h_lat)
    itf = ContactHeatInterface(sub, *WATER)
    ref = None
    for gap in (0.1, 0.35, 0.6, 0.85):
        x, vol, layer = _layers(geom, dx, edge, width, 3, gap * dx, (0.15, 0.1))
        rows, cols, w, wet, z, h = itf.weights(x, vol, np.full(len(x), dx))
        assert np.all(layer[cols] == 0)
        t_w = np.where(wet, 1e-7, 0.0)
        hA = itf.conductance(t_w, 1e-9, rows, cols, w, z, h, sub.n_surface)
        got = (wet, rows, cols, w, hA)
        if ref is None:
            ref = got
            area = float(sub.surface_area[wet].sum())
            line = {"planar": 1.0, "axisymmetric": 2 * math.pi * edge, "3d": width}[geom]
            assert abs(area - _area(geom, edge, width)) <= line * h_lat
            assert np.all(hA[wet] > 0)
            continue
        for a, b in zip(ref, got, strict=True):
            assert np.array_equal(a, b)


def _exact_heat(geom, t, T, r1, span):
    """Ideal contact heat [J (per m in planar)] at time t <= T over a region whose edge
    moves from 0 to r1 over T at constant speed, each point wetted when the edge passes
    it: 2 C int_0^{r(t)} sqrt(t - t_w(r)) dA(r), t_w = T r / r1."""
    def dA(r):
        return {"planar": 1.0, "axisymmetric": 2 * math.pi * r, "3d": span}[geom]

    edge = r1 * t / T
    return 2.0 * C * quad(lambda r: math.sqrt(t - T * r / r1) * dA(r), 0.0, edge,
                          epsabs=0, epsrel=1e-12)[0]


def spreading_history_error(geom, n_per_r1, gap=0.6, steps_per_cell=2.1, wetting=None,
                            samples=10):
    """Relative error of the ideal contact heat over the interface's wetted-node history
    (accumulated as coupling.substrate_heat does) against the ideal contact heat over the
    true history, the largest difference over ``samples`` times T k / samples
    (k = 1..samples) over the exact heat at T: two layers
    of fluid cells (spacing dx = r1 / n_per_r1) spreading from 0 to r1 = 40 um over
    T = 2 us (3D: a straight contact line across the width), riding ``gap`` dx above the
    wall; surface cells dx / 2.3 and a coupling step in which the edge moves
    1/steps_per_cell cells: edge, cell centres and nodes in general position, as the
    particles of a run are (an exact tie, a node on a footprint's edge, is counted)."""
    r1, T = 40e-6, 2e-6
    dx = r1 / n_per_r1
    width = 1.25 * r1
    span = 10e-6  # 3D: the strip's extent along the contact line
    sub = _surface(geom, width, dx / 2.3, span)
    kw = {} if wetting is None else {"wetting": wetting}
    itf = ContactHeatInterface(sub, *WATER, **kw)
    steps = int(round(steps_per_cell * r1 / dx))
    dt = T / steps
    marks = {int(round(steps * k / samples)) for k in range(1, samples + 1)}
    Q, err = 0.0, []
    for k in range(1, steps + 1):
        edge = r1 * k * dt / T  # positions at the end of the step (as the driver)
        x, vol, _ = _layers(geom, dx, edge, width, 2, gap * dx, span=span)
        itf.step(x, np.full(len(x), TF), vol, dt, h=np.full(len(x), dx))
        wet = ~np.isnan(itf.t_wet)
        tw = (itf.t - dt) - itf.t_wet[wet]
        Q += float(np.sum(sub.surface_area[wet] * C * dt * step_mean_inv_sqrt(tw, dt)))
        if k in marks:
            err.append(Q - _exact_heat(geom, k * dt, T, r1, span))
    return float(np.max(np.abs(err))) / _exact_heat(geom, T, T, r1, span)


@pytest.mark.parametrize("geom, gap", [("planar", 0.6), ("axisymmetric", 0.6),
                                       ("planar", 0.0), ("axisymmetric", 0.0),
                                       pytest.param("3d", 0.6, marks=pytest.mark.slow)])
def test_spreading_contact_heat_converges(geom, gap):
    """A contact region spreading from 0 to r1 at constant speed, the fluid riding
    ``gap`` dx above the wall (at 0.6 the earlier criterion chi(z/h) wetted nothing:
    error 1; at 0 it wetted, but from the start of the step that wetted a node: order 1.0,
    planar 5.4e-2, 2.7e-2, 1.3e-2), at r1/dx = 8, 16, 32: the ideal contact heat over
    the wetted-node history converges to the ideal contact heat over the true history
    (exact: 2 C int sqrt(t - t_w(r)) dA).
    The edge's rounding to a cell and to a node has zero mean and the wetting time is the
    midpoint of the step that wetted the node, so the error comes from the last cell
    wetted before each time, where sqrt(t - t_w) is not smooth: order 3/2 expected.
    Measured (largest error over 10 times / Q(T)): planar 2.6e-2, 9.2e-3, 3.8e-3;
    axisymmetric 5.5e-2, 1.6e-2, 8.0e-3; 3D 2.3e-2, 8.7e-3, 3.7e-3 (order 1.39 / 1.39 /
    1.33 from 8 to 32; pairwise 0.98-1.8: the rounding is quasi-periodic in dx), the
    same at either height.  Checked:
    the error falls at each refinement, the order from 8 to 32 is >= 1.2 and the error
    at 32 is below 1 %."""
    errs = np.array([spreading_history_error(geom, n, gap) for n in (8, 16, 32)])
    order = math.log(errs[0] / errs[-1]) / math.log(4.0)
    assert np.all(np.diff(errs) < 0), errs
    assert order >= 1.2, (errs, order)
    assert errs[-1] < 0.01, errs


def test_wetted_nodes_hold_while_the_layer_lifts_off():
    """A layer wetted at a gap of 0.2 dx that lifts to 1.3 dx for a step (as the fluid
    under the droplet job's impact point does) keeps its nodes wetted, sampled and dated
    from the first wetting; lifted beyond ``stay_gap`` (2.4 dx) or moved off laterally,
    the nodes dry.  A fresh layer at 1.3 dx does not wet (it enters within one cell)."""
    dx, dt = 1e-6, 1e-9
    width = 12 * dx
    sub = _surface("planar", width, 0.5 * dx)
    itf = ContactHeatInterface(sub, *WATER)

    def layer(gap, shift=0.0):
        x, vol, _ = _layers("planar", dx, 6 * dx, width, 2, gap * dx)
        x[:, 0] += shift
        return x, vol

    def step(gap, shift=0.0):
        x, vol = layer(gap, shift)
        itf.step(x, np.full(len(x), TF), vol, dt, h=np.full(len(x), dx))
        return ~np.isnan(itf.t_wet)

    fresh = ContactHeatInterface(sub, *WATER)
    x, vol = layer(1.3)
    assert not fresh.weights(x, vol, np.full(len(x), dx))[3].any()
    wet0 = step(0.2)
    t0 = itf.t_wet[wet0].copy()
    assert wet0.sum() > 0
    for gap in (1.3, 0.2, 1.3):
        assert np.array_equal(step(gap), wet0)
        assert np.array_equal(itf.t_wet[wet0], t0)
        assert itf.last["heat"][wet0].min() > 0.0
    assert not step(2.4).any()
    step(0.2)
    moved = step(1.3, shift=3 * dx)  # the layer slides away: its old edge dries
    assert moved.sum() > 0 and not moved[itf.X[:, 0] < 2.5 * dx].any()
