"""spfem_core: a compact numba-compiled 2D explicit Smoothed Particle Finite Element Method.

Particles are the mesh nodes; the mesh is a Delaunay triangulation filtered by an alpha
shape; strain is smoothed over node-based cells so that all state lives on particles.
No I/O and no UI here: see ``workflows`` for study files and results.

Importing the package imports no numba: ``geometry`` and ``settings`` are plain Python, which
the study reader uses before anything is compiled.  Every module with kernels imports
``spfem_core.jit`` first, which sets the numba cache policy before any kernel compiles.
``MaterialTable``, ``Scene`` and ``SolverSettings`` are loaded on first use.
"""

__version__ = "0.1.0"

__all__ = ["MaterialTable", "Scene", "SolverSettings", "__version__"]

_LAZY = {"MaterialTable": "spfem_core.materials.table", "Scene": "spfem_core.scene",
         "SolverSettings": "spfem_core.settings"}


def __getattr__(name: str):
    """The names of ``__all__`` from their modules, imported on first use (PEP 562)."""
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'spfem_core' has no attribute {name!r}")
