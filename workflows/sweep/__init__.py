"""Parameter studies: a study with ``[sweep]`` runs once per case, all cases on one dask cluster.

- :mod:`workflows.sweep.run`: the cases, their folders, the engine, ``study.nc``;
- :mod:`workflows.sweep.results`: ``study.nc`` (the FOS over the sweep's dimensions);
- :mod:`workflows.sweep.figures`: FOS against each swept field, and the map of a grid;
- :mod:`workflows.sweep.report`: the table of cases printed at the end.

The cases themselves come from :func:`workflows.study.reading.sweep_cases`.
"""
