"""Fuzzing the command with mutated study files: every input ends cleanly, in one line at most,
and no result it writes is silent nonsense the files themselves can show.

    python -m verification.fuzz_study_files [--examples 300] [--random] [--bases lines,seepage] [--keep DIR]

Small valid studies (``BASES``: an elastic block settling under gravity, a coarse slope whose
strength-reduction search makes a few short runs, a sweep of two cases over a slope made by
``[geometry.slope]``, the slope with water and loads, a runout, the slope drawn as lines in
engineers' units, the same section with its lines read from CSV and DXF files beside the study, the
slope as a probabilistic study of 3 realisations (two correlated random variables, verdict mode),
with random fields of c and phi, with steady seepage (rain, a seepage face, heads at the sides), and
as uniform and adaptive refinement studies of 4 levels) are mutated by hypothesis: a value replaced
by another type, a huge, tiny, negative, zero, NaN or infinite number, a key removed, renamed or
written twice, bytes corrupted, the text saved as UTF-16 or Latin-1; or a value of the right type
against the study's own scales (``_semantic``: a vertex 1e-12-1e-3 m from another, gravity turned or
of 0 to 1e4 m/s2, durations from 1e-9 s, SRF tolerances and failure displacements out of scale, a
material region or water line off the domain, supports removed, a section's layer lines crossing,
above the ground or off the section, its base at the ground; the domain cut close to the slope's
crest and toe (``_narrow_box``); a field in kPa, MPa or kN/m3 and its SI twin, given twice, huge or
tiny (``_units``); the random variables' distributions, spreads, bounds, correlations, paths (units
in the path), realisations and verdicts (``_probabilistic``); the random fields' scales against the
domain, spreads, distributions, properties (dilation against friction) and correlations
(``_random_field``); the seepage conditions, rain that may pond, tolerances and unsaturated bands
(``_seepage``); the refinement's mode, levels, ratio and budgets (``_refinement``)); or a line file
beside the study (``_csv_file``: NaN, x decreasing, one point, a huge field, binary bytes, another
delimiter, a BOM; ``_dxf_file``: written by ezdxf as LWPOLYLINE or POLYLINE, with arcs (bulges),
mirrored (extrusion (0, 0, -1)), without vertices, on another layer, in other ``$INSUNITS``, cut
short). Each mutant is written with its line files into a scratch folder and run through the command
in this process (``typer.testing.CliRunner``).

It must end with exit 0, complete result files (no ``*.tmp``) and nothing on stderr but warnings
(lines with ``warning:``, after a case's name in a study of many: no numpy warning), or with exit 2,
one line on stderr that starts with ``error:`` and nothing written, or, for a valid study whose
numbers drive the solver past its limits (a boundary pushed at tens of metres per second), with
exit 1 and one line saying the run diverged (after any warning lines the study's scene gave, such
as water over unponded ground), the finished stages' files complete; never a traceback (an
exception escaping the command, or one printed) and never another exit code.  After exit 0 or 1
the oracle reads what the command wrote (``silent_nonsense``), each file against the study text it
carries, h its ``geometry.spacing_m``:

(a) a mechanism at the domain's edge: a ``summary.nc`` whose slip line enters or exits within h of
    a side of the domain that a support of the strength-reduction stage holds (half the side's
    height at least) must say ``box_decides = 1``, or the command's output "the box decides";
(b) heads above the ground surface: in a ``seepage.nc``, no particle on the ground surface may
    have a total head more than h / 10 above its elevation unless ponded water or a
    ``total_head`` or ``pressure_head`` condition holds its head;
(c) a slip line that leaves the moving mass: every point of ``slip_x, slip_y`` (and of a
    probabilistic study's slip envelope) lies within the domain, within h (above its base and
    below its ground, between its sides), and the line's two ends lie on the ground, within h.

``tests/test_fuzz_study_files.py`` runs a bounded number of examples; this script prints the
outcome counts of as many as asked (with ``--keep``, failures are counted and their inputs kept
rather than stopping at the first), and what the oracle read ("checked: ...").
"""

from __future__ import annotations

import argparse
import functools
import math
import re
import sys
import tempfile
import time
import tomllib
import warnings
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from verification.study_text import (
    box_m,
    coarse_slope_stages,
    coarse_slope_text,
    elastic_soil,
    gravity,
    held_base_and_sides,
    study_text,
)
from workflows.cli import app
from workflows.distributions import DISTRIBUTIONS, FIELD_DISTRIBUTIONS
from workflows.random_field.correlation import CORRELATION_MODELS
from workflows.study.toml_text import to_toml

BLOCK = study_text("block", {"polygon_m": box_m(2.0, 1.0), "spacing_m": 0.25}, [elastic_soil()],
                   [{"name": "settle", "kind": "relaxation", "max_duration_s": 0.5, "record_interval_s": 0.05}],
                   loads=gravity(), boundary=held_base_and_sides(None),
                   monitors=[{"name": "top", "x_m": 1.0, "y_m": 1.0}])
"""An elastic block settling under gravity: a stage study."""

SLOPE = coarse_slope_text()
"""The coarse drained slope that computes an FOS in seconds (``verification.study_text``)."""

SWEEP = (
    '[study]\nname = "sweep"\n\n[geometry]\nspacing_m = 1.0\n\n'
    "[geometry.slope]\nheight_m = 5.0\ngradient = 2.0\nfoundation_depth_m = 2.0\n\n"
    + SLOPE[SLOPE.index("[[materials]]"):SLOPE.index("[[boundary]]")]  # no supports: the slope form makes them
    + SLOPE[SLOPE.index("[[stages]]"):]
    + '\n[sweep]\ncombination = "grid"\n\n[[sweep.axes]]\npath = "materials.soil.cohesion_pa"\nvalues = [8e3, 12e3]\n'
)
"""The slope as a slope form, swept over two cohesions."""

WATER = (
    SLOPE.replace('name = "slope"', 'name = "water"', 1).replace("[[boundary]]", (
        "[water]\nphreatic_line_m = [[-1.0, 6.0], [31.0, 3.5]]\npond_level_m = 3.5\n\n"
        '[[loads.strip]]\nname = "surcharge"\nx_start_m = 1.0\nx_end_m = 4.0\npressure_pa = 10e3\n\n'
        '[[loads.line]]\nname = "post"\nx_m = 5.0\nforce_n_m = 5e3\n\n'
        "[loads.seismic]\nhorizontal_coefficient = 0.1\n\n[[boundary]]"), 1)
    .replace("friction_deg = 20.0", "friction_deg = 20.0\nsaturated_density_kg_m3 = 2100.0\ntensile_strength_pa = 1e3", 1)
)
"""The slope with pore and ponded water, surface loads, a seismic load and a tension cut-off."""

RUNOUT = (
    SLOPE[:SLOPE.index("[[stages]]")].replace('name = "slope"', 'name = "runout"', 1)
    .replace('model = "drucker_prager"', 'model = "mohr_coulomb"', 1)
    .replace("friction_deg = 20.0", 'friction_deg = 20.0\nsoftening = "linear"\nresidual_cohesion_pa = 1e3\n'
             "softening_end_strain = 0.05", 1)
    + SLOPE[SLOPE.index("[[stages]]"):SLOPE.index('[[stages]]\nname = "srf"')]
    + '[[stages]]\nname = "flow"\nkind = "runout"\nstrength_factor = 1.5\nmax_duration_s = 0.5\n'
    "record_interval_s = 0.05\n\n[output]\nanimation_interval_s = 0.25\n"
)
"""The slope with a softening soil, failing in a runout stage, with an animation."""

SECTION = study_text(
    "section",
    {"spacing_m": 1.0, "section": {"ground_m": [[0.0, 8.0], [10.0, 8.0], [20.0, 3.0], [30.0, 3.0]], "base_y_m": 0.0,
                                   "layers": [{"material": "clay", "below_m": [[0.0, 4.0], [30.0, 2.5]],
                                               "above_m": [[0.0, 1.0], [30.0, 0.5]]}]}},
    [{"name": "soil", "model": "drucker_prager", "unit_weight_kn_m3": 20.0, "youngs_modulus_pa": 1e8,
      "poisson_ratio": 0.3, "cohesion_kpa": 10.0, "friction_deg": 20.0},
     {"name": "clay", "model": "tresca", "unit_weight_kn_m3": 19.0, "youngs_modulus_mpa": 50.0, "poisson_ratio": 0.45,
      "undrained_shear_strength_kpa": 40.0}],
    coarse_slope_stages(), loads=gravity())  # no supports: the section makes them
"""The slope drawn as lines ([geometry.section]) with a layer between two lines, in kPa, MPa and kN/m3."""

LINES = (
    SECTION.replace('name = "section"', 'name = "lines"', 1)
    .replace("ground_m = [[0.0, 8.0], [10.0, 8.0], [20.0, 3.0], [30.0, 3.0]]", 'ground_m = "ground.csv"', 1)
    .replace("below_m = [[0.0, 4.0], [30.0, 2.5]]", 'below_m = "section.dxf#CLAY_TOP"', 1)
    .replace("above_m = [[0.0, 1.0], [30.0, 0.5]]", 'above_m = "section.dxf#clay_base"', 1)
    .replace("unit_weight_kn_m3 = 20.0", "unit_weight_kn_m3 = 20.0\nsaturated_unit_weight_kn_m3 = 21.0", 1)
    .replace("unit_weight_kn_m3 = 19.0", "unit_weight_kn_m3 = 19.0\nsaturated_unit_weight_kn_m3 = 20.0", 1)
    .replace("[loads]", '[water]\nphreatic_line_m = "water.csv"\n\n[loads]', 1)
)
"""The section of SECTION with its lines in files beside the study (``line_files``): the ground and
the water in CSV files, the clay's two lines on two layers of a DXF drawing (one named in another case)."""

GROUND_M = [[0.0, 8.0], [10.0, 8.0], [20.0, 3.0], [30.0, 3.0]]
WATER_M = [[0.0, 5.0], [12.0, 4.5], [30.0, 2.0]]
DXF_LINES_M = {"CLAY_TOP": [[0.0, 4.0], [30.0, 2.5]], "CLAY_BASE": [[0.0, 1.0], [30.0, 0.5]]}


def _csv_text(points, delimiter: str = ",", header: bool = True) -> str:
    return ("x" + delimiter + "y\n" if header else "") + "".join(f"{x}{delimiter}{y}\n" for x, y in points)


def _dxf_bytes(lines: dict, *, kind: str = "LWPOLYLINE", mirrored: bool = False, bulge: float = 0.0,
               bulge_at: int = -2, units: int = 6, reverse: bool = False) -> bytes:
    """A DXF drawing (ezdxf) with each line of ``lines`` (layer -> points) on its layer: as ``kind``
    (LWPOLYLINE, POLYLINE, POLYLINE3D or LINE, the last of the first and last points), drawn right to left
    (``reverse``), mirrored in CAD (extrusion (0, 0, -1): object x = -x, bulges negated), with an arc of
    ``bulge`` from each line's vertex ``bulge_at`` to the next, in ``$INSUNITS`` ``units``."""
    import io

    import ezdxf

    document = ezdxf.new()
    document.header["$INSUNITS"] = units
    space = document.modelspace()
    for layer, points in lines.items():
        vertices = [[x, y, 0.0] for x, y in points]
        if bulge:
            vertices[min(bulge_at, len(vertices) - 2) if bulge_at >= 0 else bulge_at][2] = bulge
        if reverse:  # drawn from its other end: segment j is segment n - 2 - j turned round, its bulge negated
            n = len(vertices)
            vertices = [[x, y, -vertices[n - 2 - j][2] if j < n - 1 else 0.0]
                        for j, (x, y, _) in enumerate(vertices[::-1])]
        attributes = {"layer": layer}
        if mirrored and kind in ("LWPOLYLINE", "POLYLINE"):
            attributes["extrusion"] = (0.0, 0.0, -1.0)
            vertices = [[-x, y, -b] for x, y, b in vertices]
        if kind == "LWPOLYLINE":
            space.add_lwpolyline(vertices, format="xyb", dxfattribs=attributes)
        elif kind == "POLYLINE":
            line = space.add_polyline2d([(x, y) for x, y, _ in vertices], dxfattribs=attributes)
            for vertex, (_, _, b) in zip(line.vertices, vertices):
                vertex.dxf.bulge = b
        elif kind == "POLYLINE3D":
            space.add_polyline3d([(x, y, 0.0) for x, y, _ in vertices], dxfattribs=attributes)
        else:
            space.add_line(vertices[0][:2], vertices[-1][:2], dxfattribs=attributes)
    stream = io.StringIO()
    document.write(stream)
    return stream.getvalue().encode("utf-8")


LINE_FILES = {
    "ground.csv": _csv_text(GROUND_M).encode(),
    "water.csv": _csv_text(WATER_M, ";").encode(),
}
"""The line files of LINES but its drawing (``section.dxf``, made by ``_dxf_bytes`` when first asked)."""

PROBABILISTIC = (
    SLOPE.replace('name = "slope"', 'name = "probabilistic"', 1)
    + "\n[probabilistic]\nrealisations = 3\ncompute = \"verdict\"\nfactor = 1.2\n"
    "correlation = [[1.0, -0.5], [-0.5, 1.0]]\n\n"
    '[[probabilistic.variables]]\npath = "materials.soil.cohesion_pa"\ndistribution = "lognormal"\ncov = 0.3\n\n'
    '[[probabilistic.variables]]\npath = "materials.soil.friction_deg"\ndistribution = "truncated_normal"\n'
    "std = 2.0\nlow = 15.0\nhigh = 25.0\n"
)
"""The slope as a probabilistic study: 3 realisations of a lognormal cohesion and a truncated normal
friction angle, correlated, each judged by one run at F = 1.2."""

RANDOM_FIELD = (
    SLOPE.replace('name = "slope"', 'name = "random_field"', 1)
    + "\n[probabilistic]\nrealisations = 3\ncompute = \"verdict\"\nfactor = 1.2\n\n[random_field]\nseed = 1\n\n"
    '[[random_field.properties]]\nname = "c"\nmaterial = "soil"\nproperty = "cohesion_pa"\n'
    'distribution = "lognormal"\ncov = 0.3\ntheta_x_m = 10.0\ntheta_y_m = 2.0\n\n'
    '[[random_field.properties]]\nname = "phi"\nmaterial = "soil"\nproperty = "friction_deg"\n'
    'distribution = "normal"\nstd = 2.0\ntheta_x_m = 10.0\ntheta_y_m = 2.0\ncorrelated_with = "c"\n'
    "correlation = -0.5\n"
)
"""The slope with random fields of cohesion and friction angle (correlated), 3 realisations."""

SEEPAGE = coarse_slope_text(
    "seepage", soil={"cohesion_pa": 15e3, "saturated_density_kg_m3": 2100.0, "permeability_m_s": 1e-5},
    seepage={"unsaturated_band_m": 1.0, "boundary": [
        {"name": "rain", "condition": "infiltration", "y_min_m": 3.0, "flux_m_s": 1e-7},
        {"name": "face", "condition": "seepage_face", "x_min_m": 10.0, "x_max_m": 20.0, "y_min_m": 3.01},
        {"name": "left", "condition": "total_head", "x_max_m": 0.0, "total_head_m": 5.0},
        {"name": "right", "condition": "total_head", "x_min_m": 30.0, "total_head_m": 2.0}]})
"""The slope with steady seepage: rain on the crest and the toe, a seepage face, heads at both sides."""

REFINEMENT = (
    SLOPE.replace('name = "slope"', 'name = "refinement"', 1).replace("max_runs = 4", "max_runs = 8", 1)
    + '\n[refinement]\nmode = "uniform"\nspacings_m = [1.0, 0.8409, 0.7071, 0.5946]\nfos_tolerance = 0.01\n'
)
"""The slope at four uniform spacings (each level's search of up to 8 runs)."""

ADAPTIVE = (
    SLOPE.replace('name = "slope"', 'name = "adaptive"', 1).replace("max_runs = 4", "max_runs = 8", 1)
    + '\n[refinement]\nmode = "adaptive"\nmax_levels = 4\nmax_particles = 2000\nfos_tolerance = 0.01\n'
)
"""The slope refined along its shear band, 4 levels at most, 2,000 particles at most."""

BASES = {"block": BLOCK, "slope": SLOPE, "sweep": SWEEP, "water": WATER, "runout": RUNOUT, "section": SECTION,
         "lines": LINES, "probabilistic": PROBABILISTIC, "random_field": RANDOM_FIELD, "seepage": SEEPAGE,
         "refinement": REFINEMENT, "adaptive": ADAPTIVE}
NEW_FEATURES = ("lines", "probabilistic", "random_field", "seepage", "refinement", "adaptive")
"""The bases of the features of issue 46 (lines from files, units, probabilistic studies, random
fields, seepage, refinement)."""

ODD_VALUES = st.one_of(
    st.sampled_from([0, -1, 1, 2, 10**30, -(10**30), 0.0, -0.0, 1e-300, -1e-300, 1e308, -1e308, math.inf, -math.inf,
                     math.nan, True, False, "", "x", "nan", [], [0.0], [[0.0, 0.0]], {"a": 1}]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(),
    st.text(max_size=8),
)


def _leaves(data: dict, prefix: tuple = ()) -> list[tuple]:
    """Paths (tuples of keys and list indices) of every value in a study dict, at any depth
    (``geometry.slope.height_m``, ``sweep.axes[0].values``)."""
    paths = []
    for key, value in data.items():
        if isinstance(value, dict):
            paths += _leaves(value, prefix + (key,))
        elif isinstance(value, list) and value and all(isinstance(e, dict) for e in value):
            for i, entry in enumerate(value):
                paths += _leaves(entry, prefix + (key, i))
        else:
            paths.append(prefix + (key,))
    return paths


def _container(data: dict, path: tuple):
    node = data
    for part in path[:-1]:
        node = node[part]
    return node


def _semantic(draw, data: dict) -> None:
    """One mutation within a field's type but against the study's own scales (near-degenerate
    geometry relative to h, gravity direction, durations and tolerances against the response,
    regions against the domain, water levels against the ground, supports taken away)."""
    stages = data.get("stages", [])
    polygon = data.get("geometry", {}).get("polygon_m")
    choices = ["gravity", "duration", "supports"]
    choices += ["vertex", "region"] if polygon else []
    choices += ["tolerance", "failure"] if any(s.get("kind") == "strength_reduction" for s in stages) else []
    section = data.get("geometry", {}).get("section")
    choices += ["line", "base"] if section else []
    choice = draw(st.sampled_from(choices))
    if choice == "gravity":
        angle = math.radians(draw(st.sampled_from([0.0, 30.0, 90.0, 135.0, 180.0, 270.0])))
        g = draw(st.sampled_from([0.0, 1e-6, 10.0, 1e4]))
        data.setdefault("loads", {})["gravity_m_s2"] = [g * math.sin(angle), -g * math.cos(angle)]
    elif choice == "duration":
        stage = draw(st.sampled_from(stages))
        key = "duration_s" if "duration_s" in stage else "max_duration_s"
        stage[key] = draw(st.sampled_from([1e-9, 1e-4, 1e-3, 0.01, 0.1]))
    elif choice == "supports":
        if draw(st.booleans()) or not stages:
            data.pop("boundary", None)
        else:
            draw(st.sampled_from(stages))["boundary"] = []
    elif choice == "vertex":
        i = draw(st.integers(0, len(polygon) - 1))
        offset = draw(st.sampled_from([1e-12, 1e-9, 1e-6, 1e-3]))
        x, y = polygon[i]
        polygon.insert(i + 1, [x + offset, y])  # a vertex next to another, or a sliver
    elif choice == "region":
        shift = draw(st.sampled_from([0.5, 1e3, -1e3]))
        data["materials"][-1]["region_m"] = [[x + shift, y] for x, y in polygon]
        if draw(st.booleans()):
            data["materials"][-1]["phreatic_line_m"] = [[-1e3, draw(st.sampled_from([-1e3, 1e3, 7.9]))],
                                                        [1e3, 0.0]]
    elif choice == "line":  # a layer's line crossing the other, above the ground, off the section, one point
        layer = section["layers"][0]
        key = draw(st.sampled_from(["below_m", "above_m"]))
        layer[key] = draw(st.sampled_from([
            [[0.0, 0.5], [30.0, 5.0]], [[0.0, 20.0], [30.0, 20.0]], [[100.0, 1.0], [130.0, 1.0]],
            [[0.0, 2.0]], [[0.0, 2.0], [0.0, 3.0]], [[-1e6, 2.0], [1e6, 2.0]], [[0.0, 1.0 + 1e-12], [30.0, 0.5]]]))
    elif choice == "base":
        section["base_y_m"] = draw(st.sampled_from([3.0, 3.0 - 1e-9, 2.999, -1e6, 7.9]))
    elif choice == "tolerance":
        stage = next(s for s in stages if s.get("kind") == "strength_reduction")
        stage["tolerance"] = draw(st.sampled_from([1e-12, 1e-6, 1e-4, 1e-2, 0.5]))
    else:
        stage = next(s for s in stages if s.get("kind") == "strength_reduction")
        stage[draw(st.sampled_from(["failure_displacement_m", "displacement_floor_m"]))] = draw(
            st.sampled_from([1e-9, 0.04, 1.0, 1e6]))


def _narrow_box(draw, data: dict) -> None:
    """The domain cut close to the slope behind the crest and beyond the toe (its supports, seepage
    conditions, monitors and surface loads moved with its sides), at the base's spacing or half of it:
    a mechanism that reaches the sides, where the box and not the soil decides."""
    geometry = data["geometry"]
    geometry["spacing_m"] = draw(st.sampled_from([geometry.get("spacing_m", 1.0), 0.5]))
    if "slope" in geometry:
        slope = geometry["slope"]
        height_m = slope.get("height_m", 5.0)
        slope["crest_length_m"] = draw(st.sampled_from([0.1, 0.5, 1.0])) * height_m
        slope["toe_length_m"] = draw(st.sampled_from([0.1, 0.5, 1.0])) * height_m
        return
    polygon = geometry["polygon_m"]
    left_m, right_m = min(x for x, _ in polygon), max(x for x, _ in polygon)
    new_left_m = draw(st.sampled_from([left_m, left_m + 5.0, left_m + 8.0, left_m + 9.5]))
    new_right_m = draw(st.sampled_from([right_m, right_m - 5.0, right_m - 8.0, right_m - 9.5]))
    geometry["polygon_m"] = [[new_left_m if x == left_m else new_right_m if x == right_m else x, y]
                             for x, y in polygon]
    boxes = [*data.get("boundary", []), *data.get("seepage", {}).get("boundary", [])]
    for box in boxes:
        if box.get("x_max_m") == left_m:
            box["x_max_m"] = new_left_m
        if box.get("x_min_m") == right_m:
            box["x_min_m"] = new_right_m
    for monitor in data.get("monitors", []):
        monitor["x_m"] = min(max(monitor["x_m"], new_left_m), new_right_m)
    loads = data.get("loads", {})
    for load in [*loads.get("strip", []), *loads.get("line", [])]:  # behind the crest: on the ground left
        for key in ("x_start_m", "x_end_m", "x_m"):
            if key in load:
                load[key] += new_left_m - left_m


WEIGHTS = {"unit_weight_kn_m3": "density_kg_m3", "saturated_unit_weight_kn_m3": "saturated_density_kg_m3"}


def _unit_fields(data, found: list) -> list:
    """(table, key) of every field in Pa, kPa, MPa, kg/m3 or kN/m3 anywhere in the study dict."""
    if isinstance(data, dict):
        for key, value in data.items():
            if isinstance(value, (dict, list)):
                _unit_fields(value, found)
            elif key.endswith(("_pa", "_kpa", "_mpa")) or key in WEIGHTS or key in WEIGHTS.values():
                found.append((data, key))
    elif isinstance(data, list):
        for entry in data:
            _unit_fields(entry, found)
    return found


def _spellings(key: str) -> list[tuple[str, float]]:
    """Every spelling of the field ``key`` with the factor from its unit to SI: cohesion_pa, cohesion_kpa,
    cohesion_mpa; density_kg_m3 and unit_weight_kn_m3 (at g = 10 m/s2)."""
    for weight, density in WEIGHTS.items():
        if key in (weight, density):
            return [(density, 1.0), (weight, 100.0)]
    stem = key.rsplit("_", 1)[0]
    return [(f"{stem}_pa", 1.0), (f"{stem}_kpa", 1e3), (f"{stem}_mpa", 1e6)]


def _units(draw, data: dict) -> None:
    """A field in engineering units against its SI twin: written in another unit (the same value),
    given in two, given as a number of the other unit, or a huge or tiny number (``_spellings``)."""
    fields = _unit_fields(data, [])
    if not fields:
        return
    table, key = draw(st.sampled_from(fields))
    spellings = _spellings(key)
    factor = dict(spellings)[key]
    other, other_factor = draw(st.sampled_from([s for s in spellings if s[0] != key]))
    how = draw(st.sampled_from(["twin", "both", "as_other", "extreme"]))
    value = table[key]
    if how == "twin" and isinstance(value, (int, float)):
        table[other] = value * factor / other_factor
        del table[key]
    elif how == "both":
        table[other] = value
    elif how == "as_other":  # the number of one unit written in the field of another: 10e3 in cohesion_kpa
        table[other] = value
        del table[key]
    else:
        table[key] = draw(st.sampled_from([10**400, -(10**400), 1e300, 1e30, 1e12, 1e-12, 1e-300, 0.0, -1.0,
                                           math.nan, math.inf]))


def _probabilistic(draw, data: dict) -> None:
    """One change of ``[probabilistic]`` and its variables (module doc)."""
    table = data["probabilistic"]
    variables = table.get("variables", [])
    choice = draw(st.sampled_from(["compute", "realisations", "distribution", "spread", "correlation", "bounds",
                                   "path", "mean", "fields"] if variables else ["compute", "realisations", "fields"]))
    if choice == "compute":
        table["compute"] = draw(st.sampled_from(["verdict", "fos"]))
        table["factor"] = draw(st.sampled_from([0.5, 1.0, 1.2, 1.4, 2.0, 1e-6, 1e6]))
    elif choice == "realisations":
        table["realisations"] = draw(st.sampled_from([1, 2, 3, 4]))
        table["method"] = draw(st.sampled_from(["monte_carlo", "latin_hypercube"]))
        table["seed"] = draw(st.sampled_from([0, 1, 2**31, 2**63 - 1, 2**64]))
        if draw(st.booleans()):
            table["pf_interval_width"] = draw(st.sampled_from([1e-9, 0.5, 0.999]))
    elif choice == "fields":
        table["keep_fields"] = draw(st.sampled_from(["failed", "all", "none"]))
        table["keep_fields_first"] = draw(st.sampled_from([0, 1, 4, 10**6]))
    else:
        variable = draw(st.sampled_from(variables))
        if choice == "distribution":
            variable["distribution"] = draw(st.sampled_from(list(DISTRIBUTIONS)))
        elif choice == "spread":  # zero, tiny, usual and huge spreads; std and cov both or neither
            for key in ("std", "cov"):
                variable.pop(key, None)
            for key in draw(st.sampled_from([["std"], ["cov"], ["std", "cov"], []])):
                variable[key] = draw(st.sampled_from([0.0, 1e-300, 1e-12, 0.01, 0.3, 1.0, 10.0, 1e6]))
        elif choice == "correlation":
            table["correlation"] = draw(st.sampled_from([
                [[1.0, 0.99], [0.99, 1.0]], [[1.0, 1.0], [1.0, 1.0]], [[1.0, -1.0], [-1.0, 1.0]],
                [[1.0, 0.5], [0.3, 1.0]], [[1.0]], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                [[1.0, 2.0], [2.0, 1.0]], [[1.0, math.nan], [math.nan, 1.0]], [[1.0, -0.9], [-0.9, 1.0]],
                [[2.0, 0.0], [0.0, 2.0]], [1.0, 0.0]]))
        elif choice == "bounds":
            low, high = draw(st.sampled_from([(15.0, 15.0), (25.0, 15.0), (-1e3, 1e3), (19.999999, 20.000001),
                                              (1e6, 2e6), (0.0, 1e-300), (-math.inf, math.inf), (None, 22.0)]))
            variable.pop("low", None)
            variable.pop("high", None)
            if low is not None:
                variable["low"] = low
            variable["high"] = high
        elif choice == "path":  # units in the path: the field as the file spells it, or in another spelling
            variable["path"] = draw(st.sampled_from([
                "materials.soil.cohesion_pa", "materials.soil.cohesion_kpa", "materials.soil.cohesion_mpa",
                "materials.soil.density_kg_m3", "materials.soil.unit_weight_kn_m3", "materials.soil.youngs_modulus_mpa",
                "materials.soil.friction_deg", "materials.soil.poisson_ratio", "materials.clay.cohesion_pa",
                "geometry.spacing_m", "stages.srf.duration_s", "loads.gravity_m_s2", "output.animation_interval_s",
                "probabilistic.factor", "materials.soil", ""]))
        else:
            variable["mean"] = draw(st.sampled_from([0.0, -1.0, 1e-300, 10.0, 10e3, 1e12, 1e300]))


def _random_field(draw, data: dict) -> None:
    """One change of ``[random_field]`` and its properties (module doc)."""
    table = data["random_field"]
    field = draw(st.sampled_from(table["properties"]))
    choice = draw(st.sampled_from(["theta", "spread", "distribution", "property", "correlation", "material",
                                   "realisation", "single"]))
    if choice == "theta":  # against the 30 m by 8 m domain
        field["theta_x_m"] = draw(st.sampled_from([1e-3, 0.1, 1.0, 10.0, 30.0, 60.0, 100.0, 1e4]))
        field["theta_y_m"] = draw(st.sampled_from([1e-3, 0.5, 2.0, 8.0, 30.0, 1e4]))
        field["correlation_model"] = draw(st.sampled_from(list(CORRELATION_MODELS)))
    elif choice == "spread":
        for key in ("std", "cov", "mean"):
            field.pop(key, None)
        field[draw(st.sampled_from(["std", "cov"]))] = draw(st.sampled_from([1e-300, 1e-9, 0.01, 0.3, 1.0, 10.0,
                                                                             1e6]))
        if draw(st.booleans()):
            field["mean"] = draw(st.sampled_from([0.0, -10.0, 1e-300, 10.0, 10e3, 1e12]))
    elif choice == "distribution":
        field["distribution"] = draw(st.sampled_from(list(FIELD_DISTRIBUTIONS)))
    elif choice == "property":  # dilation against friction, units, properties the material lacks
        field["property"] = draw(st.sampled_from([
            "dilation_deg", "cohesion_kpa", "friction_deg", "youngs_modulus_pa", "density_kg_m3",
            "unit_weight_kn_m3", "poisson_ratio", "undrained_shear_strength_pa", "permeability_m_s",
            "tensile_strength_pa", "name"]))
        if field["property"] == "dilation_deg":
            for key in ("std", "cov", "correlated_with", "correlation"):
                field.pop(key, None)
            field.update(mean=draw(st.sampled_from([2.0, 10.0, 19.0])), cov=draw(st.sampled_from([0.1, 0.5])),
                         distribution="lognormal")
            if len(table["properties"]) > 1:
                table["properties"] = [field]
    elif choice == "correlation":
        field["correlated_with"] = draw(st.sampled_from(["c", "phi", "nothing"]))
        field["correlation"] = draw(st.sampled_from([-0.999, -0.5, 0.0, 0.999, 1.0]))
    elif choice == "material":
        field["material"] = draw(st.sampled_from(["clay", "SOIL", ""]))
    elif choice == "realisation":
        table[draw(st.sampled_from(["seed", "realisation"]))] = draw(st.sampled_from([0, 7, 2**32, 2**63 - 1]))
    else:  # one realisation of the fields, not a probabilistic study
        data.pop("probabilistic", None)


def _seepage(draw, data: dict) -> None:
    """One change of ``[seepage]`` (module doc)."""
    table = data["seepage"]
    conditions = table["boundary"]
    choice = draw(st.sampled_from(["rain", "condition", "box", "tolerance", "band", "pond", "heads", "face",
                                   "permeability"]))
    if choice == "rain":  # up to rain the ground cannot take (k = 1e-5 m/s), and beyond the bound of 10 k
        rain = next(c for c in conditions if c["name"] == "rain")
        rain["flux_m_s"] = draw(st.sampled_from([1e-12, 1e-8, 1e-6, 1e-5, 5e-5, 1e-4, 1e-3, -1e-6]))
        rain["condition"] = draw(st.sampled_from(["infiltration", "infiltration", "inflow"]))
    elif choice == "condition":
        entry = draw(st.sampled_from(conditions))
        for key in ("total_head_m", "pressure_head_m", "flux_m_s"):
            entry.pop(key, None)
        entry["condition"] = draw(st.sampled_from(["total_head", "pressure_head", "seepage_face", "inflow",
                                                   "infiltration", "no_flow"]))
        value = {"total_head": ("total_head_m", [-10.0, 0.0, 5.0, 8.0, 20.0, 100.0]),
                 "pressure_head": ("pressure_head_m", [0.0, -1.0, 1.0, 10.0]),
                 "inflow": ("flux_m_s", [1e-7, -1e-7, 1e-5]), "infiltration": ("flux_m_s", [1e-7, 1e-5])}
        if entry["condition"] in value:
            key, values = value[entry["condition"]]
            entry[key] = draw(st.sampled_from(values))
    elif choice == "box":
        entry = draw(st.sampled_from(conditions))
        for key in ("x_min_m", "x_max_m", "y_min_m", "y_max_m"):
            entry.pop(key, None)
        entry.update(draw(st.sampled_from([{}, {"y_min_m": 1e3}, {"x_min_m": 10.0, "x_max_m": 10.0},
                                           {"x_min_m": 29.5}, {"y_max_m": 0.0}])))
    elif choice == "tolerance":
        table["tolerance"] = draw(st.sampled_from([1e-300, 1e-12, 1e-9, 1e-3, 0.0099]))
        table["max_iterations"] = draw(st.sampled_from([1, 2, 10, 2000]))
    elif choice == "band":
        table["unsaturated_band_m"] = draw(st.sampled_from([0.0, 0.01, 1.0, 10.0, 1e6]))
        table["residual_permeability"] = draw(st.sampled_from([1e-12, 1e-3, 0.5, 0.999]))
    elif choice == "pond":  # ponded water against the heads of the conditions
        data["water"] = {"pond_level_m": draw(st.sampled_from([2.0, 4.0, 8.0, 10.0, 100.0]))}
        if draw(st.booleans()):
            data["water"]["pond_x_min_m"] = 20.0
    elif choice == "heads":  # no condition holds a head
        table["boundary"] = [c for c in conditions if c["condition"] != "total_head"]
    elif choice == "face":  # the water that reaches the face has no way out
        table["boundary"] = [c for c in conditions if c["name"] != "face"]
    else:
        soil = data["materials"][0]
        soil[draw(st.sampled_from(["permeability_m_s", "permeability_ratio", "permeability_angle_deg"]))] = draw(
            st.sampled_from([1e-300, 1e-12, 0.01, 1.0, 90.0, 1e3]))


def _refinement(draw, data: dict) -> None:
    """One change of ``[refinement]``, within a few cheap levels (module doc)."""
    table = data["refinement"]
    choice = draw(st.sampled_from(["mode", "spacings", "levels", "budget", "tolerance", "indicator", "jitter"]))
    if choice == "mode":
        table["mode"] = draw(st.sampled_from(["uniform", "adaptive"]))
    elif choice == "spacings":
        table["spacings_m"] = draw(st.sampled_from([
            [1.0, 0.8409, 0.7071, 0.5946], [1.0, 0.9, 0.8], [1.0, 1.0, 0.9, 0.8], [0.5946, 0.7071, 0.8409, 1.0],
            [1.0, 0.8, 0.6, 1e-4], [2.5, 2.0, 1.6, 1.3], [1.0, 0.95, 0.9, 0.85, 0.8]]))
    elif choice == "levels":
        table.pop("spacings_m", None)
        table["levels"] = draw(st.sampled_from([4, 5, 10]))
        table["ratio"] = draw(st.sampled_from([1.05, 1.1, 1.414, 2.0]))
        if table["levels"] == 10:
            table["ratio"] = 1.1  # ten levels, the finest at 0.42 h: cheap
    elif choice == "budget":
        table["max_particles"] = draw(st.sampled_from([100, 300, 2000]))
        table["max_levels"] = draw(st.sampled_from([4, 5]))
        table["target_uncertainty"] = draw(st.sampled_from([1e-9, 0.005, 0.2]))
    elif choice == "tolerance":
        table["fos_tolerance"] = draw(st.sampled_from([1e-3, 0.01, 0.02, 0.05]))
    elif choice == "indicator":
        table["indicator"] = draw(st.sampled_from(["plastic_work", "plastic_strain", "mechanism"]))
        table["band_reach"] = draw(st.sampled_from([1.0, 3.0, 20.0]))
    else:
        table["jitter"] = draw(st.sampled_from([0.0, 0.1, 0.29]))


CSV_ODDITIES = ("nan", "inf", "decreasing", "one point", "huge field", "binary", "semicolon", "tab", "space", "pipe",
                "bom", "utf-16", "decimal comma", "three columns", "blank lines", "empty", "header only",
                "many points")


def _csv_file(draw, points, oddity: str) -> bytes:
    """A CSV line file of ``points`` with one ``oddity`` (``CSV_ODDITIES``)."""
    rows = [list(p) for p in points]
    if oddity in ("nan", "inf"):
        rows[draw(st.integers(0, len(rows) - 1))][draw(st.integers(0, 1))] = oddity
    if oddity == "decreasing":
        rows = rows[::-1]
    if oddity == "one point":
        rows = rows[:1]
    if oddity == "many points":  # a surveyed line: 2,000 points with centimetre noise
        xs = [rows[0][0] + (rows[-1][0] - rows[0][0]) * i / 1999 for i in range(2000)]
        ys = [float(y) for y in np.interp(xs, [r[0] for r in rows], [r[1] for r in rows])]
        rows = [[x, y + 0.01 * math.sin(37.0 * i)] for i, (x, y) in enumerate(zip(xs, ys))]
    delimiter = {"semicolon": ";", "tab": "\t", "space": " ", "pipe": "|"}.get(oddity, ",")
    text = _csv_text(rows, delimiter)
    if oddity == "decimal comma":
        text = text.replace(",", ";").replace(".", ",")
    elif oddity == "three columns":
        text = "".join(line + ",0\n" for line in text.splitlines())
    elif oddity == "blank lines":
        text = text.replace("\n", "\r\n\r\n")
    elif oddity == "empty":
        text = ""
    elif oddity == "header only":
        text = "x,y\n"
    elif oddity == "huge field":
        text += "1" * 200_000 + ",1\n"
    if oddity == "binary":
        return bytes(draw(st.lists(st.integers(0, 255), min_size=1, max_size=64)))
    if oddity == "bom":
        return text.encode("utf-8-sig")
    if oddity == "utf-16":
        return text.encode("utf-16")
    return text.encode("utf-8")


DXF_ODDITIES = ("polyline", "polyline3d", "line", "reversed", "arc", "mirrored", "mirrored arc", "no vertices",
                "another layer", "two on a layer", "units", "truncated", "binary", "empty", "ground")


def _dxf_file(draw, data: dict, oddity: str) -> bytes:
    """``section.dxf`` of LINES with one ``oddity`` (``DXF_ODDITIES``); "ground" draws the ground on a
    layer too, a face dished or bulged by an arc, and the study reads it from there."""
    lines = dict(DXF_LINES_M)
    options = {}
    if oddity in ("polyline", "polyline3d", "line"):
        options["kind"] = {"polyline": "POLYLINE", "polyline3d": "POLYLINE3D", "line": "LINE"}[oddity]
    elif oddity == "reversed":
        options.update(reverse=True, kind=draw(st.sampled_from(["LWPOLYLINE", "POLYLINE"])))
    elif oddity in ("arc", "mirrored arc", "mirrored"):
        options.update(kind=draw(st.sampled_from(["LWPOLYLINE", "POLYLINE"])), mirrored=oddity != "arc",
                       bulge=0.0 if oddity == "mirrored" else draw(st.sampled_from([0.02, -0.05, 0.3, 1.0])))
    elif oddity == "units":
        options["units"] = draw(st.sampled_from([0, 1, 2, 4, 5, 99]))
    elif oddity == "another layer":
        lines["CLAY_OLD"] = lines.pop(draw(st.sampled_from(sorted(lines))))
    elif oddity == "ground":
        lines["GROUND"] = GROUND_M
        data["geometry"]["section"]["ground_m"] = draw(st.sampled_from(["section.dxf#GROUND", 'section.dxf#GR"OUND',
                                                                        "section.dxf", "section.dxf#"]))
        options.update(bulge=draw(st.sampled_from([0.0, 0.1, 0.3, -0.3, 1.0])), bulge_at=1, kind=draw(st.sampled_from(
            ["LWPOLYLINE", "POLYLINE"])), mirrored=draw(st.booleans()))
    raw = _dxf_bytes(lines, **options)
    if oddity == "no vertices" or oddity == "two on a layer":
        import io

        import ezdxf

        document = ezdxf.read(io.StringIO(raw.decode("utf-8")))
        layer = draw(st.sampled_from(sorted(lines)))
        space = document.modelspace()
        if oddity == "no vertices":
            for entity in list(space.query("LWPOLYLINE")):
                if entity.dxf.layer == layer:
                    space.delete_entity(entity)
            space.add_polyline2d([], dxfattribs={"layer": layer})
        else:
            space.add_lwpolyline([(0.0, 2.0), (30.0, 1.5)], dxfattribs={"layer": layer})
        stream = io.StringIO()
        document.write(stream)
        raw = stream.getvalue().encode("utf-8")
    elif oddity == "truncated":
        raw = raw[:draw(st.integers(0, len(raw) - 1))]
    elif oddity == "binary":
        raw = bytes(draw(st.lists(st.integers(0, 255), min_size=1, max_size=64)))
    elif oddity == "empty":
        raw = b""
    return raw


def _line_file(draw, data: dict, beside: dict) -> None:
    """One line file of LINES replaced by an odd one (``_csv_file``, ``_dxf_file``)."""
    name = draw(st.sampled_from(["ground.csv", "water.csv", "section.dxf"]))
    if name == "section.dxf":
        beside[name] = _dxf_file(draw, data, draw(st.sampled_from(DXF_ODDITIES)))
    else:
        beside[name] = _csv_file(draw, GROUND_M if name == "ground.csv" else WATER_M,
                                 draw(st.sampled_from(CSV_ODDITIES)))


@dataclass(frozen=True)
class StudyFiles:
    """A mutant: the study file's bytes and the line files beside it (name -> bytes)."""

    study: bytes
    beside: dict = field(default_factory=dict)


@functools.cache
def base_line_files() -> dict:
    return {**LINE_FILES, "section.dxf": _dxf_bytes(DXF_LINES_M)}


def _feature(draw, data: dict) -> None:
    """One change of a feature the study has: a field's units, the domain cut close to a slope, or its
    probabilistic, random-field, seepage or refinement table."""
    stages = data.get("stages", [])
    srf = any(isinstance(s, dict) and s.get("kind") == "strength_reduction" for s in stages)
    geometry = data.get("geometry", {})
    present = {"units": bool(_unit_fields(data, [])),
               "box": srf and ("slope" in geometry or "polygon_m" in geometry) and "refinement" not in data,
               "probabilistic": "probabilistic" in data and "random_field" not in data,
               "random_field": "random_field" in data, "seepage": "seepage" in data, "refinement": "refinement" in data}
    choice = draw(st.sampled_from([name for name, there in present.items() if there]))
    {"units": _units, "box": _narrow_box, "probabilistic": _probabilistic, "random_field": _random_field,
     "seepage": _seepage, "refinement": _refinement}[choice](draw, data)


@st.composite
def mutated_study_file(draw, bases: tuple = tuple(sorted(BASES))) -> StudyFiles:
    """One mutant of one of ``bases`` (module doc): the study file's bytes and its line files."""
    base = draw(st.sampled_from(sorted(bases)))
    text = BASES[base]
    beside = dict(base_line_files()) if base == "lines" else {}
    data = tomllib.loads(text)
    kinds = ["value", "value", "value", "remove", "rename", "duplicate", "bytes", "encoding", "semantic", "semantic",
             "feature", "feature", "feature", "feature", "unchanged"]
    kind = draw(st.sampled_from(kinds + ["line_file"] * 4 * bool(beside)))
    path = draw(st.sampled_from(_leaves(data)))
    node, key = _container(data, path), path[-1]
    if kind == "value":
        node[key] = draw(ODD_VALUES)
        text = to_toml(data)
    elif kind == "remove":
        del node[key]
        text = to_toml(data)
    elif kind == "rename":
        node[key + draw(st.sampled_from(["_", "s", "x"]))] = node.pop(key)
        text = to_toml(data)
    elif kind == "semantic":
        _semantic(draw, data)
        text = to_toml(data)
    elif kind == "feature":
        _feature(draw, data)
        text = to_toml(data)
    elif kind == "line_file":
        _line_file(draw, data, beside)
        text = to_toml(data)
    elif kind == "duplicate":
        line = draw(st.sampled_from([row for row in text.splitlines() if " = " in row]))
        text = text.replace(line, line + "\n" + line, 1)
    raw = text.encode("utf-8")
    if kind == "bytes":
        position = draw(st.integers(0, len(raw) - 1))
        raw = raw[:position] + bytes([draw(st.integers(0, 255))]) + raw[position + 1:]
    elif kind == "encoding":
        raw = text.replace('"soil"', '"sôil"').encode(draw(st.sampled_from(["utf-16", "latin-1", "utf-32"])))
    return StudyFiles(raw, beside)


@dataclass
class Outcome:
    """How the command ended on one input."""

    exit_code: int
    stderr: str
    traceback: str = ""
    problems: list[str] = field(default_factory=list)
    checked: Counter = field(default_factory=Counter)  # what the oracle read: slip lines, seepage files


HEAD_TOLERANCE_PER_SPACING = 0.1
"""(b): a total head more than this fraction of the spacing above a ground particle's elevation is
water standing above the ground."""


@dataclass(frozen=True)
class Domain:
    """A study's domain as the oracle sees it: its polygon, spacing h, sides, ground and base."""

    polygon_m: np.ndarray
    spacing_m: float

    @classmethod
    def of(cls, study) -> Domain:
        return cls(np.asarray(study.geometry.polygon_m, dtype=float), float(study.geometry.spacing_m))

    @property
    def sides_m(self) -> tuple[float, float]:
        return float(self.polygon_m[:, 0].min()), float(self.polygon_m[:, 0].max())

    def ground_m(self, x_m) -> np.ndarray:
        """The ground surface (the polygon's upper boundary) at ``x_m``, within the sides."""
        from spfem_core.geometry import surface_height_m

        return surface_height_m(self.polygon_m, np.clip(np.asarray(x_m, dtype=float), *self.sides_m))

    def base_m(self, x_m) -> np.ndarray:
        """The polygon's lower boundary at ``x_m``: the upper boundary of the polygon mirrored in y."""
        from spfem_core.geometry import surface_height_m

        return -surface_height_m(self.polygon_m * [1.0, -1.0], np.clip(np.asarray(x_m, dtype=float), *self.sides_m))


def _stored_study(path: Path):
    """The study a result file was computed from (its ``study`` attribute), or None."""
    import netCDF4

    from workflows.study.reading import parse_study

    with netCDF4.Dataset(path) as nc:
        text = nc.getncattr("study") if "study" in nc.ncattrs() else None
    return None if text is None else parse_study(text)


def _supported_sides(study, domain: Domain) -> list[float]:
    """x of each side of the domain (its leftmost and rightmost abscissa, at least h high) that a support
    of the strength-reduction stage holds along half its height at least."""
    h = domain.spacing_m
    active = study.strength_reduction.boundary if study.strength_reduction is not None else None
    held = []
    for side_m in domain.sides_m:
        low, high = float(domain.base_m(side_m)), float(domain.ground_m(side_m))
        if high - low < h:
            continue
        points = np.column_stack([np.full(21, side_m), np.linspace(low, high, 21)])
        if any(np.count_nonzero(b.holds(points, h)) >= 11 for b in study.boundary
               if active is None or b.name in active):
            held.append(side_m)
    return held


def _line_problems(name: str, x_m: np.ndarray, y_m: np.ndarray, domain: Domain, ends: bool) -> list[str]:
    """(c): the points of a slip line (or envelope) outside the domain, within h; with ``ends``, an end
    off the ground."""
    h = domain.spacing_m
    keep = np.isfinite(x_m) & np.isfinite(y_m)
    x_m, y_m = x_m[keep], y_m[keep]
    if x_m.size == 0:
        return []
    left_m, right_m = domain.sides_m
    outside = ((x_m < left_m - h) | (x_m > right_m + h) | (y_m > domain.ground_m(x_m) + h)
               | (y_m < domain.base_m(x_m) - h))
    problems = []
    if outside.any():
        k = int(np.argmax(outside))
        problems.append(f"{name}: {np.count_nonzero(outside)} of its {x_m.size} points lie outside the domain by "
                        f"more than h = {h:g} m, the first ({x_m[k]:.4g}, {y_m[k]:.4g}) m")
    for end, (x, y) in (("entry", (x_m[0], y_m[0])), ("exit", (x_m[-1], y_m[-1]))):
        if ends and abs(y - float(domain.ground_m(x))) > h:
            problems.append(f"{name}: its {end} ({x:.4g}, {y:.4g}) m is not on the ground (at "
                            f"{float(domain.ground_m(x)):.4g} m there)")
    return problems


def _summary_problems(path: Path, said: str, checked: Counter) -> list[str]:
    """(a) and (c) on a case's ``summary.nc`` (module doc)."""
    import netCDF4

    study = _stored_study(path)
    if study is None:
        return [f"{path.name}: no study text"]
    domain = Domain.of(study)
    with netCDF4.Dataset(path) as nc:
        if "slip_x" not in nc.variables:
            return []
        x_m, y_m = np.asarray(nc["slip_x"][:], dtype=float), np.asarray(nc["slip_y"][:], dtype=float)
        decides = int(nc.getncattr("box_decides")) if "box_decides" in nc.ncattrs() else None
        edges = nc.getncattr("mechanism_edges") if "mechanism_edges" in nc.ncattrs() else ""
    problems = _line_problems(f"{path.name} slip line", x_m, y_m, domain, ends=True)
    if x_m.size:
        checked["slip lines"] += 1
        h = domain.spacing_m
        sides_m = _supported_sides(study, domain)
        checked["slip lines at a supported side"] += any(abs(x - side_m) <= h for x in (x_m[0], x_m[-1])
                                                         for side_m in sides_m)
        for side_m in sides_m:
            at_side = [end for end, x in (("entry", x_m[0]), ("exit", x_m[-1])) if abs(x - side_m) <= h]
            if at_side and decides != 1 and "the box decides" not in said:
                x_end_m = x_m[0] if at_side[0] == "entry" else x_m[-1]
                problems.append(f"{path.name}: the slip line's {at_side[0]} x = {x_end_m:.4g} m lies within h = "
                                f"{h:g} m of the supported side x = {side_m:g} m, yet box_decides = {decides} and no "
                                f"'the box decides' warning (mechanism_edges: {edges!r})")
    return problems


def _envelope_problems(path: Path, checked: Counter) -> list[str]:
    """(c) on a probabilistic study's slip envelope."""
    import netCDF4

    study = _stored_study(path)
    if study is None:
        return [f"{path.name}: no study text"]
    domain = Domain.of(study)
    with netCDF4.Dataset(path) as nc:
        if "slip_envelope_x" not in nc.variables:
            return []
        x_m = np.asarray(nc["slip_envelope_x"][:], dtype=float)
        lines = {name: np.asarray(nc[f"slip_envelope_{name}"][:], dtype=float) for name in ("lower", "upper")}
    checked["slip envelopes"] += bool(np.isfinite(x_m).any())
    problems = []
    for name, y_m in lines.items():
        problems += _line_problems(f"{path.name} slip_envelope_{name}", x_m, y_m, domain, ends=False)
    return problems


def _seepage_problems(path: Path, checked: Counter) -> list[str]:
    """(b) on a ``seepage.nc`` (module doc)."""
    import netCDF4

    study = _stored_study(path)
    if study is None:
        return [f"{path.name}: no study text"]
    domain = Domain.of(study)
    with netCDF4.Dataset(path) as nc:
        x_m, y_m = np.asarray(nc["particle_x"][:], dtype=float), np.asarray(nc["particle_y"][:], dtype=float)
        head_m = np.asarray(nc["total_head"][:], dtype=float)
        condition = np.asarray(nc["particle_condition"][:], dtype=np.int64)
        names = [str(name) for name in nc["condition"][:]]
    kinds = {entry.name: entry.condition for entry in study.seepage.boundary}
    ponded = study.water is not None and study.water.pond_level_m is not None
    holding = [i for i, name in enumerate(names)
               if (i == 0 and ponded and name == "pond") or kinds.get(name) in ("total_head", "pressure_head")]
    h = domain.spacing_m
    checked["seepage files"] += 1
    on_ground = np.abs(y_m - domain.ground_m(x_m)) <= 1e-3 * h
    excess_m = np.where(on_ground & ~np.isin(condition, holding), head_m - y_m, -np.inf)
    k = int(np.argmax(excess_m))
    if excess_m[k] > HEAD_TOLERANCE_PER_SPACING * h:
        held_by = names[condition[k]] if condition[k] >= 0 else "no condition"
        return [f"{path.name}: the total head {head_m[k]:.4g} m at the ground particle ({x_m[k]:.4g}, {y_m[k]:.4g}) m "
                f"stands {excess_m[k]:.3g} m above it ({np.count_nonzero(excess_m > HEAD_TOLERANCE_PER_SPACING * h)} "
                f"such particles; its condition: {held_by}), and neither ponded water nor a head condition holds it"]
    return []


def silent_nonsense(out: Path, said: str, checked: Counter | None = None) -> list[str]:
    """What the result files in ``out`` show to be nonsense (module doc, (a) to (c)); ``said``: the
    command's output; ``checked`` counts what was read."""
    checked = Counter() if checked is None else checked
    problems = []
    for path in sorted(out.rglob("summary.nc")):
        problems += _summary_problems(path, said, checked)
    for path in sorted(out.rglob("probabilistic.nc")):
        problems += _envelope_problems(path, checked)
    for path in sorted(out.rglob("seepage.nc")):
        problems += _seepage_problems(path, checked)
    return problems


def run_command(files: StudyFiles | bytes, scratch: Path) -> Outcome:
    """Run ``spfem-fos`` in this process on a study file with its line files beside it; judge the result
    (module doc)."""
    files = files if isinstance(files, StudyFiles) else StudyFiles(files)
    study, out = scratch / "study.toml", scratch / "out"
    study.write_bytes(files.study)
    for name, raw in files.beside.items():
        (scratch / name).write_bytes(raw)
    with warnings.catch_warnings():
        warnings.simplefilter("always")  # every warning shown, as in a fresh process (not an error, as in pytest)
        result = CliRunner().invoke(app, [str(study), "--out", str(out), "--workers", "1", "--quiet"])
    outcome = Outcome(result.exit_code, result.stderr)
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        outcome.traceback = f"{type(result.exception).__name__}: {result.exception}"
        outcome.problems.append(f"an exception escaped the command: {outcome.traceback}")
    written = sorted(p.name for p in out.rglob("*")) if out.exists() else []
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    if any("Traceback (most recent call last)" in line for line in lines):
        outcome.traceback = outcome.traceback or next(line for line in lines if "Traceback" in line)
        outcome.problems.append(f"a traceback on stderr: {lines[-1][:200]}")
    if result.exit_code == 2:
        if len(lines) != 1 or not lines[0].startswith("error: "):
            outcome.problems.append(f"exit 2 without exactly one 'error:' line: {lines[:3]}")
        if written:
            outcome.problems.append(f"exit 2 but files were written: {written[:5]}")
    elif result.exit_code in (0, 1):
        if any(re.search(r"\.tmp$", name) for name in written):
            outcome.problems.append(f"a temporary file was left: {written}")
        warnings_then_error = all(line.startswith("warning: ") for line in lines[:-1])
        if result.exit_code == 1 and (not lines or "the run diverged" not in lines[-1] or not warnings_then_error):
            outcome.problems.append(f"exit 1 that is not one line saying the run diverged (after warnings): {lines[:3]}")
        others = [line[:200] for line in lines if "warning: " not in line]  # a case's warning: "case x: warning: ..."
        if result.exit_code == 0 and others:
            outcome.problems.append(f"exit 0 with stderr lines that are not warnings: {others[:3]}")
        if out.exists():
            outcome.problems += silent_nonsense(out, result.stdout + result.stderr, outcome.checked)
    else:
        outcome.problems.append(f"exit code {result.exit_code}: {lines[-1:] or outcome.traceback}")
    return outcome


def _keep(files: StudyFiles, outcome: Outcome, folder: Path) -> Path:
    """The input of a failure written to a new folder under ``folder``, with what went wrong."""
    folder.mkdir(parents=True, exist_ok=True)
    case = folder / f"failure_{len(list(folder.glob('failure_*'))):03d}"
    case.mkdir()
    (case / "study.toml").write_bytes(files.study)
    for name, raw in files.beside.items():
        (case / name).write_bytes(raw)
    (case / "problems.txt").write_text("\n".join(outcome.problems) + f"\n\nexit {outcome.exit_code}\n"
                                       f"stderr:\n{outcome.stderr}")
    return case


def fuzz(max_examples: int, counts: Counter | None = None, derandomize: bool = True, bases=tuple(BASES),
         keep: Path | None = None) -> Counter:
    """Run ``max_examples`` mutants of ``bases`` (``derandomize``: the same ones every time).  Without
    ``keep``, raise on the first that breaks a rule of the module doc; with it, count it ("traceback"
    or "oracle failure"), write its input to a folder there and go on.  Returns the count of each
    exit code and failure."""
    counts = Counter() if counts is None else counts

    @settings(max_examples=max_examples, deadline=None, derandomize=derandomize, database=None,
              suppress_health_check=list(HealthCheck))
    @given(files=mutated_study_file(tuple(bases)))
    def one(files: StudyFiles) -> None:
        with tempfile.TemporaryDirectory() as scratch:
            outcome = run_command(files, Path(scratch))
        counts[f"exit {outcome.exit_code}"] += 1
        counts.update({f"checked: {what}": n for what, n in outcome.checked.items()})
        if outcome.problems and keep is not None:
            counts["traceback" if outcome.traceback else "oracle failure"] += 1
            print(f"FAILURE ({_keep(files, outcome, keep)}): {outcome.problems}", flush=True)
            return
        assert not outcome.problems, outcome.problems

    one()
    return counts


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m verification.fuzz_study_files", description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=300)
    parser.add_argument("--random", action="store_true", help="new mutants on every call (not the derandomized set)")
    parser.add_argument("--bases", default=",".join(BASES),
                        help=f"the base studies to mutate, comma-separated (default all: {','.join(BASES)})")
    parser.add_argument("--keep", type=Path, default=None,
                        help="count failures and keep their inputs here instead of stopping at the first")
    args = parser.parse_args(argv)
    bases = tuple(args.bases.split(","))
    unknown = [name for name in bases if name not in BASES]
    if unknown:
        parser.error(f"unknown bases {unknown}; known: {', '.join(BASES)}")
    start = time.perf_counter()
    counts = fuzz(args.examples, derandomize=not args.random, bases=bases, keep=args.keep)
    print(f"{sum(counts[f'exit {code}'] for code in range(256))} inputs in {time.perf_counter() - start:.0f} s: "
          + ", ".join(f"{n} {what}" for what, n in sorted(counts.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
