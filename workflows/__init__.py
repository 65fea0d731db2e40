"""Everything around the SPFEM core: study files, running them, result files, the command line.

``spfem_core`` computes; ``workflows`` reads a study file (:mod:`workflows.study`), builds the
core's scene from it (:mod:`workflows.scene_builder`), runs its stages
(:mod:`workflows.runner`), writes the results (:mod:`workflows.results`) and offers all of
it as the ``spfem-fos`` command (:mod:`workflows.cli`).
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("spfem-fos")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0+unknown"
