"""Everything around the SPFEM core: study files, running them, result files, the command line.

``spfem_core`` computes; ``workflows`` reads a study file (:mod:`workflows.study`), builds the
core's scene from it (:mod:`workflows.scene`, with one room per kind: :mod:`workflows.materials`,
:mod:`workflows.loads`, :mod:`workflows.stages`), runs it as its study type
(:mod:`workflows.study_types`: a single study or a sweep, whose cases :mod:`workflows.cases`
computes: their stages, or for a strength-reduction study the factor-of-safety search on dask,
:mod:`workflows.fos`), writes the results (:mod:`workflows.output`) and offers all of it as the
``spfem-fos`` command (:mod:`workflows.cli`).
"""
