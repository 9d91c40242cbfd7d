"""Declarative scene parameters: one declaration feeds validation, defaults and the docs.

A :class:`Section` is a TOML table (``[sph]``), an array of tables (``[[blocks]]``,
``repeated=True``) or a table of named tables (``[materials.<name>]``, ``open_keys=True``).
It holds :class:`Param` declarations with type, unit, default, bounds and a one-line
description, and optionally nested sub-sections (``[coupling.mesh]``,
``[[heat.boundaries]]``).  Validation turns the parsed TOML dict into read-only
:class:`Record` objects with every default filled in and raises :class:`SceneError` -- one
line naming the file and the key -- on the first mistake.  A key declared with ``when=``
is present in the record only when its condition holds (read it with ``"key" in rec``
first, as cross-key checks must).

One module per job, every name re-exported here:

* :mod:`~sphfem.schema.declarations` -- parameter types, :class:`Param`, :class:`Section`,
  :class:`Record`, :class:`FrozenDict`;
* :mod:`~sphfem.schema.validate` -- :func:`validate_section` and the value conversions;
* :mod:`~sphfem.schema.registry` -- :data:`SECTIONS` (every top-level section) and
  :data:`MODULE_SECTIONS` (physics-module name -> its section), filled at import time by
  :func:`register_section` / :func:`register_module`; the core sections are registered by
  :mod:`sphfem.scene`, a physics package registers its own in its ``__init__``;
* :mod:`~sphfem.schema.docs` -- ``docs/scenes.md`` from the declarations.

A module's section may only appear in a scene that lists the module.  Sub-sections may
themselves be repeated (``[[heat.boundaries]]``) or open-key tables.

``python -m sphfem.schema`` rewrites ``docs/scenes.md`` from the registered declarations.
"""

from sphfem.errors import SceneError
from sphfem.schema.declarations import (
    BOOLS,
    CUSTOM,
    REQUIRED,
    STRINGS,
    TEMPERATURE,
    VECTOR,
    FrozenDict,
    Param,
    Record,
    Section,
    to_plain,
)
from sphfem.schema.docs import all_sections, describe_markdown, docs_path, write_docs
from sphfem.schema.registry import (
    ENTRY_POINT_GROUP,
    MODULE_SECTIONS,
    SECTIONS,
    import_for,
    known_modules,
    physics_packages,
    plugin_packages,
    register_module,
    register_section,
    unregister,
)
from sphfem.schema.validate import (
    Context,
    convert,
    key_text,
    parse_temperature,
    suggest,
    validate_section,
    validate_table,
)

__all__ = [
    "BOOLS", "CUSTOM", "ENTRY_POINT_GROUP", "MODULE_SECTIONS", "REQUIRED", "SECTIONS",
    "STRINGS", "TEMPERATURE", "VECTOR", "Context", "FrozenDict", "Param", "Record",
    "SceneError", "Section", "all_sections", "convert", "describe_markdown", "docs_path",
    "import_for", "key_text", "known_modules", "parse_temperature", "physics_packages",
    "plugin_packages", "register_module", "register_section", "suggest", "to_plain",
    "unregister", "validate_section", "validate_table", "write_docs",
]
