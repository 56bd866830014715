"""The package version, in a leaf module that imports nothing.

Why not ``msd_bench.__version__`` from below: the package root is the public
face (``load_model`` reaches into io), so io importing it for a string would be
an import from a lower layer to a higher one (docs/design.md §Layers). Artifacts
and run manifests stamp this value; the root re-exports it.
"""

__version__ = "0.1.0"
"""Same as ``version`` in pyproject.toml."""
