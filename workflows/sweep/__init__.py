"""Parameter studies: a study with ``[sweep]`` runs once per case (the sweep study type).

- :mod:`workflows.sweep.study_type`: the cases, their folders, how they run and come together;
- :mod:`workflows.sweep.results`: ``study.nc`` (the FOS, or a stage study's metrics, over the
  sweep's dimensions);
- :mod:`workflows.sweep.figures`: FOS against each swept field, the map of a grid, runout charts;
- :mod:`workflows.sweep.report`: the table of cases printed at the end.

The cases themselves come from :func:`workflows.study.reading.sweep_cases`.
"""
