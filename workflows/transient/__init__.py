"""Transient unsaturated flow in a study (``[transient]``): rain and drawdown, the water at a time the
particles carry (with its suction), and the factor of safety against time.

- ``table``: the ``[transient]`` declaration and its checks;
- ``flow``: the flow on the particles' first mesh, solved, and the water at a time (``WaterAt``);
- ``results``: ``transient.nc``.

The FOS against time, a case per time, is ``workflows.fos_time``.
"""
