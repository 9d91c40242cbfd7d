"""The ``[extrusion]`` scene section of a direct-ink-writing job (declared once: validation,
defaults and docs/scenes.md).

Pure declarations: importing this module compiles nothing.  The physics module
``"extrusion"`` is listed in ``[physics] modules`` next to ``"fluid"`` (whose ``[fluid]``
section chooses the ink's solver and rheology); the run itself is
:func:`sphfem.diw.extrusion.simulate_deposit` (the nozzle appends ink particles, which the
generic driver does not allow a module to do).
"""

from __future__ import annotations

from sphfem.schema import REQUIRED, Param, Section, register_module


def _check(rec, ctx, path):
    if ctx.dim != 3:
        ctx.error("scene.dim", f"an extrusion scene is 3D (the substrate is the xy plane), "
                               f"got dim = {ctx.dim}")
    if (rec.extrusion_speed is None) == (rec.flow_rate is None):
        ctx.error(f"{path}.extrusion_speed", "give exactly one of extrusion_speed [m/s] and "
                                             "flow_rate [m^3/s]")
    blocks = ctx.core.get("blocks", ())
    fluid = [b for b in blocks if b.kind == "fluid"]
    walls = [b for b in blocks if b.kind == "wall"]
    if len(fluid) != 1:
        ctx.error("blocks", f"an extrusion scene has one fluid block (it names the ink), got "
                            f"{len(fluid)}")
    if len(walls) != 1 or walls[0].shape != "box":
        ctx.error("blocks", "an extrusion scene has one wall block of shape \"box\" (the "
                            "substrate plate)")
    sph = ctx.core.get("sph")
    if sph is not None and len(walls) == 1 and walls[0].shape == "box":
        R = sph.support_factor * sph.dx
        thick = walls[0].hi[2] - walls[0].lo[2]
        if thick < R * (1 - 1e-9):
            ctx.error("blocks", f"the substrate block {walls[0].name!r} is {thick:g} m thick; "
                                f"it needs at least the support radius R = {R:g} m of wall "
                                f"layers")
        if rec.nozzle_diameter < 2 * sph.dx * (1 - 1e-9):
            ctx.error(f"{path}.nozzle_diameter", f"{rec.nozzle_diameter:g} m is less than 2 "
                                                 f"particle spacings ({2 * sph.dx:g} m)")


EXTRUSION = Section("extrusion", (
    Param("nozzle_diameter", float, REQUIRED, unit="m", positive=True, quantity="length",
          doc="inner diameter D of the nozzle (its bore); the ink leaves through a disc of "
              "this diameter"),
    Param("standoff", float, REQUIRED, unit="m", positive=True, quantity="length",
          doc="height of the nozzle outlet above the substrate's top face"),
    Param("extrusion_speed", float, None, unit="m/s", positive=True, quantity="speed",
          doc="mean ink speed through the bore: volume flux Q = extrusion_speed pi D^2 / 4 "
              "(give this or flow_rate)"),
    Param("flow_rate", float, None, unit="m^3/s", positive=True, quantity="flux",
          doc="volume flux Q of ink out of the nozzle (give this or extrusion_speed)"),
    Param("nozzle_speed", float, REQUIRED, unit="m/s", positive=True, quantity="speed",
          doc="speed of the nozzle along its toolpath (constant, as in the thesis sec. 3.1)"),
    Param("toolpath", str, REQUIRED,
          doc="the desired path: a named case of sphfem.diw.toolpath (e.g. \"line\", "
              "\"bend90\", \"bend180-small\", \"bend180-large\") or a file"),
    Param("settle_time", float, 0.0, unit="s", ge=0.0, quantity="time",
          doc="time simulated after the nozzle reaches the end of its path (extrusion "
              "stopped, nozzle at rest) so the last ink lands"),
    Param("start_dwell", float, 0.0, unit="s", ge=0.0, quantity="time",
          doc="the nozzle extrudes at the path's start for this long before it moves "
              "(priming: the first ink reaches the substrate; 0 = start moving at once, the "
              "first ink then hangs from the nozzle until it touches down)"),
    Param("coast_distance", float, 0.0, unit="m", ge=0.0, quantity="length",
          doc="extrusion stops when the nozzle is this far (along its path) from the end, "
              "and the nozzle coasts on to the end (a slicer's coasting): the ink between "
              "the outlet and the substrate is laid along the path instead of heaping at "
              "its end; about nozzle_speed times the ink's fall time over the stand-off "
              "(0 = extrude to the end)"),
    Param("end_ramp", float, 0.0, unit="m", ge=0.0, quantity="length",
          doc="the nozzle decelerates uniformly to rest over this last distance of its path "
              "and the flux follows its speed (the bead keeps its cross-section), so the "
              "ink leaving the outlet near the end carries no speed past the end point "
              "(0 = the nozzle stops dead at the end)"),
    Param("fill_length", float, None, unit="m", positive=True, quantity="length",
          default_doc="the nozzle diameter",
          doc="length of ink column inside the bore, between the outlet and the inflow "
              "buffer (the nozzle is full at t = 0)"),
    Param("wall_layers", int, None, ge=1, default_doc="ceil(support_factor)",
          doc="layers of wall particles of the nozzle tube"),
    Param("substrate_margin", float, None, unit="m", positive=True, quantity="length",
          default_doc="4 nozzle diameters",
          doc="substrate particles are placed only within this distance (in the xy plane) "
              "of the toolpath; the rest of the substrate block is left out"),
), check=_check, doc=(
    "Direct ink writing (issue 18, thesis ch. 3): a nozzle of bore `nozzle_diameter` with "
    "its outlet `standoff` above the substrate moves along the toolpath at `nozzle_speed` "
    "and extrudes the ink of the scene's fluid block at the volume flux Q onto the "
    "substrate (the scene's box wall block; its top face is the substrate plane). Inflow: "
    "rigid layers of buffer particles move down the bore as a piston, at the speed that "
    "makes the flux exactly Q for the bore's lattice; a layer that passes the buffer's "
    "lower plane becomes ink and a new layer enters on top (sphfem.diw.extrusion). Run by "
    "sphfem.diw.extrusion.simulate_deposit or `sphfem optimize`."))

register_module("extrusion", EXTRUSION, target="sphfem.diw.extrusion:ExtrusionModule")
