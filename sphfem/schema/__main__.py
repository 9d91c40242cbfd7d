"""``python -m sphfem.schema [PATH]``: rewrite ``docs/scenes.md`` (or PATH) from the
registered declarations."""

import sys

from sphfem.schema.docs import write_docs

if __name__ == "__main__":  # importing this module (the layer tests do) writes nothing
    print(write_docs(sys.argv[1] if len(sys.argv) > 1 else None))
