"""A refinement study: the factor of safety at a sequence of particle spacings, its value as h -> 0
and its discretisation uncertainty (``[refinement]`` of a study file).

- ``table``: the ``[refinement]`` table (adaptive or uniform levels, when to stop);
- ``convergence``: the least-squares band of Eca & Hoekstra (2014) from noisy levels;
- ``adaptive``: the refined zones along a level's shear band;
- ``study_type``: the levels as cases, each after the one before, and ``refinement.nc``;
- ``results``, ``figures``: ``refinement.nc`` and the FOS against h with the fit and its band.
"""
