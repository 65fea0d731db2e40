"""A refinement study: the factor of safety at a sequence of particle spacings, extrapolated to
h -> 0 with its discretisation uncertainty (``[refinement]`` of a study file).

- ``table``: the ``[refinement]`` table (the spacings, the levels' search tolerance);
- ``convergence``: Richardson extrapolation and the grid convergence index;
- ``study_type``: the levels as cases, each after the one before, and ``refinement.nc``;
- ``figures``: the FOS against h with the extrapolation and its band.
"""
