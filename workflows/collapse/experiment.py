"""The granular column-collapse experiment of Bui, Fukagawa, Sako & Ohno (2008), digitised.

An aluminium-rod column, 0.2 m long and 0.1 m high, against a wall at x = 0 on a base at
y = 0, released at one side (``shared/reference/collapse_refs.md``).  The granular collapse
metrics compare the simulated final surface with :data:`GRANULAR_SURFACE_XY_M`.
"""

from __future__ import annotations

import numpy as np

GRANULAR_COLUMN_M = (0.2, 0.1)
"""(length, height) of the experiment's column, m."""

GRANULAR_SURFACE_XY_M = np.array(
    [
        [0.00012, 0.09923],
        [0.01960, 0.09928],
        [0.03984, 0.09587],
        [0.06004, 0.08900],
        [0.08027, 0.08444],
        [0.10008, 0.07756],
        [0.12030, 0.07223],
        [0.14013, 0.06651],
        [0.16035, 0.06157],
        [0.18016, 0.05392],
        [0.19998, 0.04744],
        [0.22020, 0.04249],
        [0.24079, 0.03485],
        [0.26219, 0.03067],
        [0.28202, 0.02649],
        [0.30224, 0.02154],
        [0.32209, 0.01890],
        [0.34231, 0.01357],
        [0.36216, 0.01093],
        [0.38240, 0.00790],
        [0.40224, 0.00372],
        [0.42209, 0.00224],
        [0.44235, 0.00152],
    ]
)
"""Experimental final free surface (x, y) in m, sorted by x, digitised to +-2 mm (23 points)."""
GRANULAR_SURFACE_XY_M.setflags(write=False)

GRANULAR_FAILURE_LINE_XY_M = np.array(
    [
        [0.02116, 0.09890],
        [0.03979, 0.09010],
        [0.05997, 0.08015],
        [0.07973, 0.06521],
        [0.09990, 0.05449],
        [0.11964, 0.03685],
        [0.13942, 0.02574],
        [0.15956, 0.01041],
        [0.17935, 0.00046],
    ]
)
"""Experimental failure line (x, y) in m in the initial column: the boundary of the material that moved."""
GRANULAR_FAILURE_LINE_XY_M.setflags(write=False)
