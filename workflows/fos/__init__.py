"""The factor of safety by strength reduction: from a study file to ``summary.nc``.

The path of a case (:func:`workflows.cases.run_cases` hands the cases of any study type to
:class:`~workflows.fos.engine.Engine`): the gravity state (:mod:`~workflows.fos.gravity`, reused
while its :mod:`~workflows.fos.keys` hold), the SRF runs as dask tasks (:mod:`~workflows.fos.task`)
on a cluster (:mod:`~workflows.fos.cluster`), chosen by the search (:mod:`~workflows.fos.search`)
and kept on disk (:mod:`~workflows.fos.run_store`); each run's verdict
(:mod:`~workflows.fos.verdict`), the FOS from the SRF-displacement curve
(:mod:`~workflows.fos.criterion`), then the case's conclusion, report and figures
(:func:`~workflows.fos.summary.conclude_case`, :mod:`~workflows.fos.report`,
:mod:`~workflows.fos.figures`).
"""
