"""``python -m sphfem.schema [PATH]``: rewrite ``docs/scenes.md`` (or PATH) from the
registered declarations."""

import sys

from sphfem.schema.docs import write_docs

print(write_docs(sys.argv[1] if len(sys.argv) > 1 else None))
