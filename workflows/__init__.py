"""Everything around the SPFEM core: study files, running them, result files, the command line.

``spfem_core`` computes; ``workflows`` reads a study file (:mod:`workflows.study`), builds the
core's scene from it (:mod:`workflows.scene`), runs its stages (:mod:`workflows.stages`) or,
for a strength-reduction study, the factor-of-safety search on dask (:mod:`workflows.fos`),
writes the results (:mod:`workflows.output`) and offers all of it as the ``spfem-fos``
command (:mod:`workflows.cli`).
"""
