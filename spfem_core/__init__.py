"""spfem_core: a compact numba-compiled 2D explicit Smoothed Particle Finite Element Method.

Particles are the mesh nodes; the mesh is a Delaunay triangulation filtered by an alpha
shape; strain is smoothed over node-based cells so that all state lives on particles.
No I/O and no UI here: see ``workflows`` for study files and results.
"""

from spfem_core import jit  # noqa: F401  (sets the numba cache policy before any kernel compiles)
from spfem_core.scene import MaterialTable, Scene, SolverSettings

__version__ = "0.1.0"

__all__ = ["MaterialTable", "Scene", "SolverSettings", "__version__"]
