"""Ground water given as lines, ru and ponded water.

- ``table`` (``[water]``): the declaration, its checks, and the warning of a line drawn above the
  ground;
- ``pressure``: what the water does to a scene's particles (pore pressure, weight, pond), from the
  lines or from the steady flow of ``[seepage]`` (``workflows.seepage.flow``), which it is given;
- ``figures``: the water drawn over a figure of the domain.
"""
