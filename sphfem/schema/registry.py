"""Which scene sections and physics modules exist: the two registries, filled at import
time, and the discovery of the packages that fill them.

* :data:`SECTIONS` -- every known top-level section by name; the core ones (``scene``,
  ``domain``, ``sph``, ``materials``, ``blocks``, ``physics``, ``time``, ``output``) are
  registered by :mod:`sphfem.scene`.
* :data:`MODULE_SECTIONS` -- the physics-module names a scene may list in
  ``[physics] modules``, each with the name of its section (or None).  The classes that
  implement the modules are in :data:`sphfem.physics.MODULES`.

A physics package registers itself, and optionally its own section, in its ``__init__``
(the section declared in its ``scene_section.py``), e.g. sphfem.heat::

    register_module("heat", HEAT, target="sphfem.heat.module:HeatConduction")

An installed package outside sphfem does the same and names itself in the entry-point
group :data:`ENTRY_POINT_GROUP`.
"""

from __future__ import annotations

import importlib
import importlib.util
import pkgutil
import re
from dataclasses import replace

from sphfem import physics
from sphfem.schema.declarations import Section

#: every top-level section a scene may contain, by name
SECTIONS: dict[str, Section] = {}
#: physics-module names a scene may list, with the name of their section (or None)
MODULE_SECTIONS: dict[str, str | None] = {}


def register_section(section: Section, *, replace_existing: bool = False) -> Section:
    """Make ``[section.name]`` a known scene section (idempotent for an equal declaration)."""
    old = SECTIONS.get(section.name)
    if old is not None and old != section and not replace_existing:
        raise ValueError(f"scene section [{section.name}] is already registered")
    SECTIONS[section.name] = section
    return section


def register_module(name: str, section: Section | None = None, *, target: str | None = None,
                    replace_existing: bool = False) -> None:
    """Register physics module ``name`` (listed in ``[physics] modules``).

    ``section``: its parameter table, allowed in a scene only when the module is listed
    (missing from such a scene, it gets its defaults).  ``target``: ``"pkg.mod:Class"``,
    forwarded to :func:`sphfem.physics.register_physics` so the driver can build it.
    """
    new = replace(section, module=name) if section is not None else None
    if name in MODULE_SECTIONS and not replace_existing:
        sec = MODULE_SECTIONS[name]
        old = SECTIONS.get(sec) if sec is not None else None
        if old != new:
            raise ValueError(f"physics module {name!r} is already registered")
    if new is not None:
        register_section(new, replace_existing=True)
    MODULE_SECTIONS[name] = section.name if section is not None else None
    if target is not None:
        physics.register_physics(name, target)


def unregister(name: str) -> None:
    """Remove module and/or section ``name`` (for tests)."""
    sec = MODULE_SECTIONS.pop(name, None)
    if sec is not None:
        SECTIONS.pop(sec, None)
    s = SECTIONS.get(name)
    if s is not None and (s.module is None or s.module == name):
        SECTIONS.pop(name, None)


def known_modules() -> list[str]:
    """Module names a scene may list: this registry plus :data:`sphfem.physics.MODULES`."""
    return list(MODULE_SECTIONS) + [n for n in physics.MODULES if n not in MODULE_SECTIONS]


#: entry-point group through which installed packages add scene sections and physics
#: modules: ``[project.entry-points."sphfem.physics"] name = "package"`` in their
#: pyproject.toml; importing ``package`` registers them (sphfem names none of them)
ENTRY_POINT_GROUP = "sphfem.physics"
#: sphfem sub-packages that never register scene sections
_NOT_PHYSICS = {"validation"}


def plugin_packages() -> dict[str, str]:
    """Installed packages that register sections, by entry-point name -> importable package
    (group :data:`ENTRY_POINT_GROUP`; those whose package cannot be found are left out)."""
    from importlib.metadata import entry_points

    found = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        pkg = ep.value.split(":")[0]
        if importlib.util.find_spec(pkg.split(".")[0]) is not None:
            found[ep.name] = pkg
    return found


def physics_packages() -> list[str]:
    """Importable packages that may register sections: sphfem sub-packages and the plugin
    packages of :func:`plugin_packages`."""
    import sphfem

    names = [f"sphfem.{m.name}" for m in pkgutil.iter_modules(sphfem.__path__)
             if m.ispkg and m.name not in _NOT_PHYSICS]
    names += list(plugin_packages().values())
    return sorted(set(names))


def import_for(name: str) -> None:
    """Import what registers module/section ``name``: ``sphfem.<name>`` and its target."""
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name or ""):
        return
    plugins = plugin_packages()
    if name in plugins:
        importlib.import_module(plugins[name])  # an installed package registering ``name``
    pkg = f"sphfem.{name}"
    spec = importlib.util.find_spec(pkg) if name not in _NOT_PHYSICS else None
    if spec is not None and spec.submodule_search_locations is not None:  # a package
        importlib.import_module(pkg)
    targets = physics.MODULES
    if name in targets and name not in MODULE_SECTIONS:
        importlib.import_module(targets[name].split(":")[0])
    if name not in MODULE_SECTIONS and name not in SECTIONS:
        # a package may register modules under other names (sphfem.solid -> "tlsph"):
        # import every physics package (their imports are cheap: no numba compilation)
        for pkg in physics_packages():
            importlib.import_module(pkg)


