"""Droplet-impact study (Park 2019 sec. 2.4.6): run the coupled scene, draw the pictures.

    python examples/droplet_impact/study.py --out DIR [--scene droplet_impact.toml]
    python examples/droplet_impact/study.py --out DIR --plots-only      # redraw a run (its
                                                                        # own recorded scene)
    python examples/droplet_impact/study.py --out DIR --sweep speed=25,50 temperature=60,100 \\
        material=alumina,silicon                                       # table of peak stress

One run writes, into DIR (next to the run's particle series, summary.json and
``substrate/`` folder of the coupling).  Times are counted from the first contact
(``t_contact_s`` of the coupling in summary.json) in units of tc = D / v:

* ``droplet_shape.png`` -- side view (slice |y| < 0.75 dx) at (t - t_contact)/tc ~ 0.25,
  0.75, 1.25, 1.75, cropped to the droplet; the droplet coloured on its own temperature
  range, the substrate's top particle layers on theirs (thesis figure 2.10);
* ``surface_maps.png`` -- substrate surface temperature and von Mises stress at the last
  output, over the spread droplet (figures 2.11-2.12);
* ``depth_profiles.png`` -- stress components and temperature against depth under the
  impact point at the last coupling step: the L2-recovered nodal fields along the line,
  the element (constant P1) von Mises stress, the probe values, and the element faces the
  line crosses, i.e. what the mesh resolves (figure 2.13);
* ``surface_temperature.png`` -- temperature of the impact point and the largest
  substrate temperature against time, figure 2.14;
* ``summary.json`` gains a ``study`` entry: peak von Mises stress (value, place, time, and
  time after contact), contact-patch diameter / D (the heated patch, where the surface
  temperature rise exceeds half its maximum), wetted diameter / D, maximum spreading ratio
  (largest lateral extent of the fluid / D over the outputs), heat transferred to the
  substrate, wall time.

Sweep mode runs one case per combination (impact speed [m/s], droplet temperature [C],
substrate material from MATERIALS) under DIR/case_*, with a progress bar, and writes
``sweep.csv`` / ``sweep.json`` with the peak von Mises stress of each.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))  # run from a checkout without installing

#: Substrate materials of the sweep at room temperature: density rho0 [kg/m^3], specific
#: heat c [J/(kg K)], conductivity k [W/(m K)], Young's modulus E [Pa], Poisson's ratio nu,
#: linear expansion alpha [1/K].  Sources (docs/validation/droplet_sweep/README.md):
#: alumina: sintered alpha-alumina, Munro, J. Am. Ceram. Soc. 80 (1997) 1919, values at 20 C;
#: silicon: single crystal, (100) wafer, E and nu along <100> (Hopcroft et al., J. MEMS 19
#: (2010) 229), k at 300 K (Glassbrenner & Slack, Phys. Rev. 134 (1964) A1058), alpha at
#: 300 K (Okada & Tokumaru, J. Appl. Phys. 56 (1984) 314), c from the CRC Handbook;
#: steel: AISI 304 stainless, annealed (ASM Handbook vol. 1, 1990);
#: glass: soda-lime silicate float glass, EN 572-1:2012 (the values it states for design).
MATERIALS = {
    "alumina": dict(rho0=3984.0, c=755.0, k=33.0, E=416e9, nu=0.231, alpha=4.6e-6),
    "silicon": dict(rho0=2329.0, c=712.0, k=148.0, E=130e9, nu=0.28, alpha=2.6e-6),
    "steel": dict(rho0=8000.0, c=500.0, k=16.2, E=193e9, nu=0.29, alpha=17.3e-6),
    "glass": dict(rho0=2500.0, c=720.0, k=1.0, E=70e9, nu=0.2, alpha=9.0e-6),
}


def run_case(data: dict, out: Path, source: str = "<study>") -> dict:
    from sphfem.api import run
    from sphfem.scene import parse_scene

    scene = parse_scene(data, source=source)
    t0 = time.perf_counter()
    summary = run(scene, out, progress=True).summary
    summary["study_wall_s"] = time.perf_counter() - t0
    return summary


def _droplet(data):
    return next(b for b in data["blocks"] if b["kind"] == "fluid")


def _read_particles(out: Path):
    from sphfem.fem.substrate import read_quiet

    pvd = out / "particles.pvd"
    frames = []
    for line in pvd.read_text().splitlines():
        if "<DataSet" in line:
            t = float(line.split('timestep="')[1].split('"')[0])
            f = line.split('file="')[1].split('"')[0]
            frames.append((t, out / f))
    return [(t, read_quiet(f)) for t, f in frames]


def case_scales(data: dict) -> tuple[float, float, float]:
    """Droplet diameter D [m], impact speed v [m/s] and tc = D / v [s] of a scene dict."""
    drop = _droplet(data)
    D = 2 * drop["radius"]
    v = float(np.linalg.norm(drop["velocity"]))
    return D, v, D / v


def _line_fields(sub_vtu, depths, xy=(0.0, 0.0)):
    """Nodal (L2-recovered) stress and dT interpolated (P1) along the vertical line under
    ``xy`` at ``depths`` [m] below the top face, the element (constant P1) stress there, and
    the element index of each point (its changes are the element faces the line crosses)."""
    from skfem import CellBasis, ElementTetP1, MeshTet1

    p = np.ascontiguousarray(sub_vtu.points.T)
    t = np.ascontiguousarray(sub_vtu.cells_dict["tetra"].T)
    mesh = MeshTet1(p, t)
    X = np.zeros((3, len(depths)))
    X[0], X[1] = xy
    X[2] = p[2].max() - np.asarray(depths)
    P = CellBasis(mesh, ElementTetP1()).probes(X)
    nodal = np.asarray(sub_vtu.point_data["stress"]).reshape(-1, 3, 3)
    S = np.einsum("pn,nij->pij", P.toarray(), nodal)
    dT = P @ np.asarray(sub_vtu.point_data["dT"]).ravel()
    cells = mesh.element_finder()(*X)
    S_el = np.asarray(sub_vtu.cell_data["stress_elem"][0]).reshape(-1, 3, 3)[cells]
    return S, dT, S_el, cells


def _von_mises(S):
    dev = S - np.einsum("...ii->...", S)[..., None, None] / 3 * np.eye(3)
    return np.sqrt(1.5 * np.einsum("...ij,...ij->...", dev, dev))


def analyse(out: Path, data: dict) -> dict:
    """Draw the PNGs and add the ``study`` entry to DIR/summary.json.

    ``data``: the run's scene as a dict (the resolved ``summary.json["scene"]`` or the
    parsed TOML).  Times are shown after the first contact ``t_contact_s`` recorded by the
    coupling (0 for runs made before it was recorded), in units of tc = D / v.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator, NullLocator, ScalarFormatter

    summary = json.loads((out / "summary.json").read_text())
    D, v, tc = case_scales(data)
    dx = data["sph"]["dx"]
    c = summary["diagnostics"]["coupling"]
    t0 = c.get("t_contact_s") or 0.0  # time origin: first contact
    frames = _read_particles(out)
    kind_of = lambda m: np.asarray(m.point_data["kind"]).ravel()  # noqa: E731
    temp_of = lambda m: np.asarray(m.point_data["T"]).ravel() - 273.15  # noqa: E731

    # -- droplet shape and temperature (side view, slice |y| < 0.75 dx) -----------------
    spread = 0.0
    for _t, m in frames:
        fl = kind_of(m) == 0
        r = np.linalg.norm(m.points[fl, :2], axis=1)
        spread = max(spread, 2 * float(r.max()) / D if fl.any() else 0.0)
    want = [0.25, 0.75, 1.25, 1.75]
    picked = [min(frames, key=lambda f, w=w: abs((f[0] - t0) / tc - w)) for w in want]
    picked = list({id(f): f for f in picked}.values())  # a short run may repeat a frame
    sl_f, sl_s = [], []
    for _t, m in picked:
        k, y = kind_of(m), np.abs(m.points[:, 1]) < 0.75 * dx
        sl_f.append(y & (k == 0))
        sl_s.append(y & ((k == 1) | (k == 2)) & (m.points[:, 2] > -3 * dx))
    Tf = np.concatenate([temp_of(m)[s] for (_t, m), s in zip(picked, sl_f, strict=True)])
    Ts = np.concatenate([temp_of(m)[s] for (_t, m), s in zip(picked, sl_s, strict=True)])
    xmax = max(float(np.abs(m.points[s, 0]).max()) for (_t, m), s in
               zip(picked, sl_f, strict=True)) + 2 * dx
    zlo = -3 * dx  # the top substrate layers: heat reaches ~ sqrt(kappa t) = 3 um
    ztop = [float(m.points[s, 2].max()) + dx for (_t, m), s in zip(picked, sl_f, strict=True)]
    width = 9.0
    heights = [width * 0.78 * (zt - zlo) / (2 * xmax) for zt in ztop]
    fig, axes = plt.subplots(len(picked), 1, figsize=(width, sum(heights) + 0.3 * len(picked)
                                                      + 0.5),
                             gridspec_kw={"height_ratios": heights}, sharex=True,
                             squeeze=False, layout="constrained")
    axes = axes[:, 0]
    norm_f = (float(Tf.min()), float(Tf.max())) if Tf.size else (0.0, 100.0)
    norm_s = (float(Ts.min()), float(Ts.max())) if Ts.size else (0.0, 1.0)
    for ax, (t, m), sf, ss, zt in zip(axes, picked, sl_f, sl_s, ztop, strict=True):
        T = temp_of(m)
        hs = ax.scatter(m.points[ss, 0] * 1e3, m.points[ss, 2] * 1e3, c=T[ss], s=7,
                        marker="s", cmap="viridis", vmin=norm_s[0], vmax=norm_s[1])
        hf = ax.scatter(m.points[sf, 0] * 1e3, m.points[sf, 2] * 1e3, c=T[sf], s=7,
                        cmap="inferno", vmin=norm_f[0], vmax=norm_f[1])
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xlim(-xmax * 1e3, xmax * 1e3)
        ax.set_ylim(zlo * 1e3, zt * 1e3)
        ax.set_aspect("equal")
        ax.set_ylabel("z [mm]")
        ax.set_title(f"(t - t_contact) / tc = {(t - t0) / tc:.2f}", fontsize=9, loc="left")
    axes[-1].set_xlabel("x [mm]  (slice |y| < 0.75 dx)")
    fig.colorbar(hf, ax=axes, label="droplet T [C]", fraction=0.04, pad=0.01)
    fig.colorbar(hs, ax=axes, label="substrate T [C]", fraction=0.04, pad=0.01)
    fig.savefig(out / "droplet_shape.png", dpi=120)
    plt.close(fig)

    # -- substrate surface maps at the last substrate output ----------------------------
    from sphfem.fem.substrate import read_quiet

    sub_dir = out / "substrate"
    vtus = sorted(sub_dir.glob("substrate_*.vtu"))
    hist = json.loads((sub_dir / "history.json").read_text())
    patch = wetted = None
    sm = read_quiet(vtus[-1]) if vtus else None
    T0 = (data.get("coupling") or {}).get("T0") or 293.15
    if sm is not None:
        P = sm.points
        top = np.abs(P[:, 2] - P[:, 2].max()) < 1e-12
        dT = np.asarray(sm.point_data["dT"]).ravel()
        vm = np.asarray(sm.point_data["von_mises"]).ravel()
        lim = min(3 * D, 1.3 * spread * D / 2 + 4 * dx)
        # triangulate beyond the shown square so its corners lie inside the nodes' hull
        near = top & (np.abs(P[:, 0]) < 1.3 * lim) & (np.abs(P[:, 1]) < 1.3 * lim)
        fig, axes = plt.subplots(1, 2, figsize=(11, 4.6), layout="constrained")
        for ax, val, lab, cm in ((axes[0], dT[near] + T0 - 273.15, "T [C]", "inferno"),
                                 (axes[1], vm[near] / 1e6, "von Mises [MPa]", "viridis")):
            levels = MaxNLocator(24).tick_values(val.min(), val.max())
            # extend="both": values a round-off outside the levels are filled, not holes
            tc_ = ax.tricontourf(P[near, 0] * 1e3, P[near, 1] * 1e3, val, levels=levels,
                                 cmap=cm, extend="both")
            ax.plot(P[near, 0] * 1e3, P[near, 1] * 1e3, ",", color="w", alpha=0.5)
            fig.colorbar(tc_, ax=ax, label=lab)
            ax.set_xlim(-lim * 1e3, lim * 1e3)
            ax.set_ylim(-lim * 1e3, lim * 1e3)
            ax.set_aspect("equal")
            ax.set_xlabel("x [mm]")
            ax.set_ylabel("y [mm]")
        t_last = hist["history"][-1]["t"]
        axes[0].set_title(f"surface temperature, (t - t_contact)/tc = {(t_last - t0) / tc:.2f}"
                          "\n(dots: FEM surface nodes)", fontsize=10)
        axes[1].set_title("surface von Mises stress (nodal, recovered)", fontsize=10)
        fig.savefig(out / "surface_maps.png", dpi=120)
        plt.close(fig)
        r = np.linalg.norm(P[top, :2], axis=1)
        dtop = dT[top]
        if dtop.max() > 0:
            patch = 2 * float(r[dtop >= 0.5 * dtop.max()].max()) / D
    _, m_last = frames[-1]
    fl = kind_of(m_last) == 0
    low = fl & (m_last.points[:, 2] < 1.5 * dx)
    if low.any():
        wetted = 2 * float(np.linalg.norm(m_last.points[low, :2], axis=1).max()) / D

    # -- depth profiles under the impact point ------------------------------------------
    probes = np.asarray(hist["probes"])
    last = hist["history"][-1]
    depth = -probes[:, 2] * 1e6
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 5.2), sharey=True,
                                 gridspec_kw={"width_ratios": [2.2, 1]}, layout="constrained")
    comps = (("xx", 0, 0), ("yy", 1, 1), ("zz", 2, 2), ("xz", 0, 2))
    if sm is not None and sm.point_data.get("stress") is not None and (
            "tetra" in sm.cells_dict):
        thick = float(np.ptp(sm.points[:, 2]))
        zz = np.concatenate([np.linspace(0, 40e-6, 400), np.geomspace(40e-6, thick, 200)[1:]])
        zz = np.clip(zz, 1e-9 * thick, thick * (1 - 1e-9))
        S, dTl, S_el, cells = _line_fields(sm, zz)
        faces = 0.5 * (zz[1:] + zz[:-1])[np.diff(cells) != 0] * 1e6
        h_top = float(faces[0]) if faces.size else thick * 1e6
        for k, (name, i, j) in enumerate(comps):
            a1.plot(S[:, i, j] / 1e6, zz * 1e6, "-", color=f"C{k}", label=f"s_{name}")
        a1.plot(_von_mises(S) / 1e6, zz * 1e6, "-", color="k", lw=1.5, label="von Mises")
        a1.plot(_von_mises(S_el) / 1e6, zz * 1e6, ":", color="k", lw=1,
                label="von Mises, element (constant per tet)")
        for f in faces:
            for ax in (a1, a2):
                ax.axhline(f, color="0.8", lw=0.5, zorder=0)
        a2.plot(dTl + T0 - 273.15, zz * 1e6, "-", color="C3", label="nodal T (mapped)")
        res = (f"FEM P1 tets; grey lines: element faces on this line (first at "
               f"{h_top:.1f} um); SPH dx = {dx * 1e6:.3g} um.  Lines: L2-recovered nodal "
               f"stress.\nMarkers: probes (the P1 strain, hence von Mises, is constant in "
               f"each element; only the thermal part follows the nodal T). Variation within "
               f"one element is not resolved.")
        fig.suptitle(res, fontsize=8.5)
    for k, (name, _i, _j) in enumerate(comps):
        a1.plot([p[name] / 1e6 for p in last["probes"]], depth, "o", color=f"C{k}", ms=4)
    a1.plot([p["von_mises"] / 1e6 for p in last["probes"]], depth, "o", color="k", ms=4,
            label="probes")
    a1.set_yscale("symlog", linthresh=20.0, linscale=1.5)
    a1.set_ylim(float(max(depth.max(), 1.0)) * 1.05, 0.0)
    ticks = sorted({0.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0} | {round(float(x)) for x in
                                                                 depth[depth > 20.0]})
    a1.set_yticks([x for x in ticks if x <= depth.max() * 1.05])
    a1.yaxis.set_major_formatter(ScalarFormatter())
    a1.yaxis.set_minor_locator(NullLocator())
    a1.set_xlabel("stress [MPa]")
    a1.set_ylabel("depth under the impact point [um] (linear to 20 um, then log)")
    a1.legend(fontsize=8)
    a1.set_title(f"(t - t_contact) / tc = {(last['t'] - t0) / tc:.2f}", fontsize=10)
    a2.plot([p["T"] - 273.15 for p in last["probes"]], depth, "o", color="C3", ms=4,
            label="probes")
    a2.set_xlabel("T [C]")
    a2.legend(fontsize=8)
    fig.savefig(out / "depth_profiles.png", dpi=120)
    plt.close(fig)

    # -- surface temperature against time ------------------------------------------------
    ts = (np.array([h["t"] for h in hist["history"]]) - t0) / tc
    fig, ax = plt.subplots(figsize=(6, 4), layout="constrained")
    ax.plot(ts, [h["probes"][0]["T"] - 273.15 for h in hist["history"]], "o-", ms=3,
            label="impact point (FEM node field)")
    ax.plot(ts, [h.get("T_region_max", np.nan) - 273.15 for h in hist["history"]], "s--",
            ms=3, label="hottest substrate particle")
    ax.axvline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("(t - t_contact) / tc")
    ax.set_ylabel("T [C]")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.savefig(out / "surface_temperature.png", dpi=120)
    plt.close(fig)

    tp = c["peak_von_mises_t_s"]
    study = {
        "tc_s": tc, "D_m": D, "impact_speed_m_s": v,
        "t_contact_s": c.get("t_contact_s"),
        "peak_von_mises_Pa": c["peak_von_mises_Pa"],
        "peak_von_mises_location_m": c["peak_von_mises_location_m"],
        "peak_von_mises_t_s": tp,
        "peak_von_mises_t_after_contact_s": (tp - t0) if tp is not None else None,
        "peak_von_mises_t_after_contact_over_tc": (tp - t0) / tc if tp is not None else None,
        "contact_patch_diameter_over_D": patch,
        "wetted_diameter_over_D": wetted,
        "max_spreading_ratio": spread,
        "heat_transferred_J": (c.get("heat") or {}).get("heat_to_solid_J"),
        "heat_balance_residual_rel": (c.get("heat") or {}).get("residual_rel"),
        "wall_s": summary["wall_s"],
        "pngs": ["droplet_shape.png", "surface_maps.png", "depth_profiles.png",
                 "surface_temperature.png"],
    }
    from sphfem.output import write_json

    summary["study"] = study
    write_json(out / "summary.json", summary)
    return study


def recorded_scene(out: Path) -> dict:
    """The scene a finished run used: ``summary.json["scene"]`` (resolved, kelvin)."""
    path = out / "summary.json"
    if not path.exists():
        raise SystemExit(f"study: {path} not found: --plots-only needs a finished run")
    summary = json.loads(path.read_text())
    if "scene" not in summary:
        raise SystemExit(f"study: {path} records no scene; pass --scene")
    return summary["scene"]


SWEEP_AXES = {"speed": "impact speed [m/s]", "temperature": "droplet temperature [C]",
              "material": f"substrate material ({', '.join(MATERIALS)})"}


def parse_sweep(specs: list[str]) -> dict:
    """``["speed=10,30", "material=glass"]`` -> the sweep's axes (unlisted ones: defaults).

    Raises SystemExit naming the known axes / materials for an unknown axis, an empty or
    non-numeric value, a repeated axis or an unknown material."""
    axes = {"speed": [50.0], "temperature": [100.0], "material": ["alumina"]}
    seen = set()
    known = "; ".join(f"{k}=... ({v})" for k, v in SWEEP_AXES.items())
    for item in specs:
        k, _, vals = item.partition("=")
        k = k.strip()
        if k not in axes:
            raise SystemExit(f"study: unknown sweep parameter {k!r} in {item!r}; known: {known}")
        if k in seen:
            raise SystemExit(f"study: sweep parameter {k!r} given twice")
        seen.add(k)
        values = [v.strip() for v in vals.split(",") if v.strip()]
        if not values:
            raise SystemExit(f"study: sweep parameter {k!r} has no values ({item!r})")
        if k == "material":
            bad = [m for m in values if m not in MATERIALS]
            if bad:
                raise SystemExit(f"study: unknown material {bad[0]!r}; known: "
                                 f"{', '.join(MATERIALS)}")
            axes[k] = values
            continue
        try:
            axes[k] = [float(v) for v in values]
        except ValueError:
            raise SystemExit(f"study: {k} values must be numbers, got {item!r}") from None
        if k == "speed" and min(axes[k]) <= 0:
            raise SystemExit(f"study: speeds must be > 0 m/s, got {item!r}")
    return axes


def case_name(speed: float, temp: float, mat: str) -> str:
    return f"case_v{speed:g}_T{temp:g}_{mat}"


def sweep_case(scene, speed: float, temp_c: float, mat: str, per_diameter: int | None,
               t_end_tc: float) -> dict:
    """The scene dict of one sweep case.

    ``scene``: a :class:`sphfem.scene.Scene`.  Its resolution lengths are scaled together to
    ``per_diameter`` particles across the droplet (:func:`sphfem.resolution.scaled_resolution`;
    None keeps them); the droplet moves at ``speed`` towards -z with c0 = 10 ``speed`` (the
    Mach number and the steps per tc stay fixed); it starts at ``temp_c`` C; the run ends at
    ``t_end_tc`` tc (tc = D / speed) with outputs every quarter of it; the coupled substrate
    (the coupling's blocks and FEM) is ``mat`` from MATERIALS under its own name.
    """
    from sphfem.resolution import scaled_resolution

    drop0 = next(b for b in scene.blocks if b.kind == "fluid")
    factor = 1.0
    if per_diameter is not None:
        dx0 = drop0.dx or scene.sph.dx
        factor = 2.0 * drop0.radius / per_diameter / dx0
    d = scaled_resolution(scene, factor)
    drop = _droplet(d)
    drop["velocity"] = [0.0] * (len(drop["velocity"]) - 1) + [-float(speed)]
    drop["temperature"] = f"{temp_c:g} C"
    d["materials"][drop["material"]]["c0"] = 10.0 * float(speed)
    cp = d["coupling"]
    props = {**d["materials"][cp["material"]], **MATERIALS[mat]}
    d["materials"] = {k: v for k, v in d["materials"].items() if k != cp["material"]}
    d["materials"][mat] = props
    for b in d["blocks"]:
        if b["name"] in cp["blocks"] or b["material"] == cp["material"]:
            b["material"] = mat
    cp["material"] = mat
    d["time"]["t_end"] = f"{t_end_tc:g} tc"
    d["output"]["every"] = f"{t_end_tc / 4:g} tc"
    d["scene"]["name"] = f"{d['scene']['name']}_{case_name(speed, temp_c, mat)}"
    return d


def sustained_peak(values) -> float | None:
    """The largest value held on two consecutive coupling steps, max_i min(v_i, v_i+1): the
    peak with single-step spikes left out (the noisy wall load, see the README)."""
    v = np.asarray([x for x in values if x is not None], dtype=float)
    return float(np.minimum(v[1:], v[:-1]).max()) if v.size > 1 else None


def sweep_row(summary: dict, speed: float, temp_c: float, mat: str,
              folder: Path | None = None) -> dict:
    """One table row from a case's summary.json (figures of
    :func:`sphfem.validation.droplet_impact.figures` plus the extremes and ideals) and, with
    ``folder``, the sustained peak von Mises from its substrate/history.json."""
    from sphfem.validation.droplet_impact import figures

    sustained = None
    hist = Path(folder) / "substrate" / "history.json" if folder is not None else None
    if hist is not None and hist.exists():
        rows = json.loads(hist.read_text())["history"]
        sustained = sustained_peak([r.get("peak_von_mises") for r in rows])

    drop = _droplet(summary["scene"])
    f = figures(summary, speed, 2.0 * drop["radius"])
    sh = summary["diagnostics"]["coupling"]["substrate_heat"]
    T_s0, T_c = sh["substrate_initial_temperature_K"], sh["ideal_contact_temperature_K"]
    return {
        "speed_m_s": speed, "droplet_T_C": temp_c, "material": mat,
        "status": summary["status"], "t_end_over_tc": summary["t"] / f["tc"],
        "max_spreading": f["spread"], "max_spreading_t_over_tc": f["spread_t_tc"],
        # the largest spread in the last 5 % of the run: still spreading, a lower bound
        "spreading_at_end": f["spread_t_tc"] >= 0.95 * summary["t"] / f["tc"],
        "heat_J": f["heat"], "heat_ideal_J": f["heat_ideal"],
        "heat_over_ideal": f["heat"] / f["heat_ideal"] if f["heat_ideal"] else None,
        "T_contact_ideal_C": T_c - 273.15,
        "T_impact_mean_C": T_s0 - 273.15 + f["T_impact"],
        "T_impact_rise_over_ideal": f["T_impact"] / (T_c - T_s0),
        "T_impact_max_C": sh["T_impact_max_K"] - 273.15,
        "peak_von_mises_MPa": f["vm_peak"] / 1e6,
        "sustained_von_mises_MPa": sustained / 1e6 if sustained is not None else None,
        "peak_von_mises_t_after_contact_over_tc": f["vm_t_tc"],
        "peak_von_mises_r_um": f["vm_r_m"] * 1e6, "peak_von_mises_z_um": f["vm_z_m"] * 1e6,
        "heat_balance_rel": f["balance"], "steps": f["steps"],
        "particles": f["particles"], "setup_s": summary.get("setup_s"),
        "wall_s": f["wall_s"],
    }


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return "" if v is None else str(v)


def write_tables(rows: list[dict], folder: Path) -> None:
    """``sweep.csv``, ``sweep.json``, ``sweep.md`` (atomic writes) and ``sweep.png`` (the
    figures against speed, one colour per substrate, one line style per temperature)."""
    from sphfem.output import atomic_write_text, write_json

    folder.mkdir(parents=True, exist_ok=True)
    write_json(folder / "sweep.json", rows)
    if not rows:
        return
    head = list(rows[0])
    atomic_write_text(folder / "sweep.csv", "\n".join(
        [",".join(head)] + [",".join(_fmt(r[k]) for k in head) for r in rows]) + "\n")
    cols = [("speed_m_s", "V m/s"), ("droplet_T_C", "T_drop C"), ("material", "substrate"),
            ("max_spreading", "D_max/D"), ("max_spreading_t_over_tc", "at t/tc"),
            ("spreading_at_end", "still spreading"),
            ("heat_J", "heat uJ"), ("heat_over_ideal", "heat/ideal"),
            ("T_impact_mean_C", "T_imp C (mean)"), ("T_contact_ideal_C", "T_contact C"),
            ("T_impact_rise_over_ideal", "rise/ideal"),
            ("peak_von_mises_MPa", "vM MPa"), ("sustained_von_mises_MPa", "vM 2-step MPa"),
            ("peak_von_mises_t_after_contact_over_tc",
                                                "vM t/tc"),
            ("peak_von_mises_r_um", "vM r um"), ("peak_von_mises_z_um", "vM z um"),
            ("setup_s", "set-up s"), ("wall_s", "stepping s"), ("status", "status"),
            ("t_end_over_tc", "reached t/tc")]
    lines = ["| " + " | ".join(c[1] for c in cols) + " |",
             "|" + "---|" * len(cols)]
    for r in rows:
        lines.append("| " + " | ".join(
            _fmt(r[k] * 1e6 if k == "heat_J" and r[k] is not None else r[k])
            for k, _ in cols) + " |")
    atomic_write_text(folder / "sweep.md", "\n".join(lines) + "\n")
    plot_sweep(rows, folder / "sweep.png")


def plot_sweep(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sphfem.output import atomic_write_bytes

    panels = (("max_spreading", "max spreading D_max / D"),
              ("heat_over_ideal", "heat into substrate / ideal contact heat"),
              ("T_impact_rise_over_ideal", "impact-point rise / ideal contact rise"),
              ("sustained_von_mises_MPa", "peak von Mises held 2 coupling steps [MPa]"))
    mats = list(dict.fromkeys(r["material"] for r in rows))
    temps = sorted({r["droplet_T_C"] for r in rows})
    fig, axes = plt.subplots(2, 2, figsize=(10, 7.5), layout="constrained")
    for ax, (key, label) in zip(axes.ravel(), panels, strict=True):
        for i, m in enumerate(mats):
            for j, T in enumerate(temps):
                rr = sorted((r for r in rows if r["material"] == m and r["droplet_T_C"] == T
                             and r[key] is not None), key=lambda r: r["speed_m_s"])
                if rr:
                    ax.plot([r["speed_m_s"] for r in rr], [r[key] for r in rr],
                            ["-", "--", ":", "-."][j % 4], marker="os^D"[j % 4],
                            color=f"C{i}", label=f"{m}, {T:g} C")
        ax.set_xlabel("impact speed [m/s]")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())


def sweep(scene, out: Path, specs: list[str], per_diameter: int | None = 32,
          t_end_tc: float = 4.0, table_dir: Path | None = None,
          table_only: bool = False) -> list[dict]:
    """Run every (speed, droplet temperature, substrate) case of ``specs`` under
    ``out/case_*`` (a case whose summary.json exists is not run again), print a progress
    line per case and write the tables (:func:`write_tables`) into ``table_dir`` (default
    ``out``) after each case.  ``table_only``: tabulate the finished cases, run nothing."""
    from sphfem.api import run
    from sphfem.scene import parse_scene

    axes = parse_sweep(specs)
    cases = list(itertools.product(axes["speed"], axes["temperature"], axes["material"]))
    table_dir = Path(table_dir) if table_dir is not None else out
    rows = []
    for i, (speed, temp, mat) in enumerate(cases, 1):
        name = case_name(speed, temp, mat)
        folder = out / name
        tag = f"sweep [{i}/{len(cases)}] {name}"
        if not (folder / "summary.json").exists():
            if table_only:
                print(f"{tag}: not run", flush=True)
                continue
            data = sweep_case(scene, speed, temp, mat, per_diameter, t_end_tc)
            print(f"{tag}: running", flush=True)
            t0 = time.perf_counter()
            run(parse_scene(data, source=name), folder, overwrite=True, raise_on_stop=False)
            print(f"{tag}: done in {time.perf_counter() - t0:.0f} s", flush=True)
        else:
            print(f"{tag}: summary exists, not run again", flush=True)
        summary = json.loads((folder / "summary.json").read_text())
        row = sweep_row(summary, speed, temp, mat, folder)
        print(f"{tag}: {row['status']}, D_max/D {row['max_spreading']:.3g}, heat/ideal "
              f"{_fmt(row['heat_over_ideal'])}, rise/ideal "
              f"{row['T_impact_rise_over_ideal']:.3g}, vM {row['peak_von_mises_MPa']:.3g} "
              f"MPa, {row['wall_s']:.0f} s", flush=True)
        rows.append(row)
        write_tables(rows, table_dir)
    write_tables(rows, table_dir)
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", default=None,
                   help="scene file (default: droplet_impact.toml; with --plots-only: the "
                        "scene recorded in DIR/summary.json)")
    p.add_argument("--out", required=True, help="output folder (must not exist, or --plots-only)")
    p.add_argument("--plots-only", action="store_true", help="redraw an existing run")
    p.add_argument("--sweep", nargs="+", metavar="AXIS=V1,V2",
                   help="speed=... [m/s], temperature=... [C], material=... "
                        f"({', '.join(MATERIALS)}); default scene: the axisymmetric one")
    p.add_argument("--per-diameter", type=int, default=32,
                   help="sweep: particles across the droplet (0: the scene's own dx)")
    p.add_argument("--t-end-tc", type=float, default=4.0, help="sweep: end time in tc")
    p.add_argument("--table-dir", default=None, help="sweep: folder of the tables (default: --out)")
    p.add_argument("--table-only", action="store_true",
                   help="sweep: tabulate the finished cases, run nothing")
    a = p.parse_args(argv)
    out = Path(a.out)
    if a.plots_only:  # the run's own scene, never a default that may differ from it
        base = recorded_scene(out)
        if a.scene is not None:
            from sphfem.scene import parse_scene

            given = parse_scene(tomllib.loads(Path(a.scene).read_text()), source=a.scene)
            if given != parse_scene(base, source=str(out / "summary.json")):
                raise SystemExit(f"study: {a.scene} is not the scene of the run in {out} "
                                 f"(see its summary.json); drop --scene to use the run's own")
        st = analyse(out, base)
        print(json.dumps(st, indent=1))
        return 0
    if a.sweep:
        from sphfem.scene import parse_scene_toml

        scene_file = a.scene or str(HERE / "droplet_impact_axisymmetric.toml")
        scene = parse_scene_toml(Path(scene_file).read_text(), source=scene_file)
        sweep(scene, out, a.sweep, per_diameter=a.per_diameter or None,
              t_end_tc=a.t_end_tc, table_dir=a.table_dir, table_only=a.table_only)
        return 0
    scene_file = a.scene or str(HERE / "droplet_impact.toml")
    base = tomllib.loads(Path(scene_file).read_text())
    if out.exists() and any(out.iterdir()):
        raise SystemExit(f"study: {out} exists and is not empty (use another --out)")
    run_case(base, out, source=scene_file)
    st = analyse(out, recorded_scene(out))
    print(json.dumps(st, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
