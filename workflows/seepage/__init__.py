"""Steady seepage: pore pressures computed from the water's boundary conditions.

- ``table`` (``[seepage]``): the boundary conditions of the flow by position, the unsaturated
  conductivity and the iteration's settings (each material's conductivity is a field of
  ``[[materials]]``);
- ``flow``: the study's flow problem on the particles' first mesh, solved (``spfem_core.seepage``)
  and passed on as a value, and the pore pressure and weight of every particle;
- ``results`` (``seepage.nc``) and ``figures`` (``seepage.png``).
"""
