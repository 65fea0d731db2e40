"""Lines read from CSV and DXF files (workflows.study.line_files) as a hostile user writes them:
every file that cannot give a line is one StudyError naming the field; a DXF line is read as CAD
draws it (arcs, mirrored object coordinates), never silently otherwise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from workflows.study import StudyError
from workflows.study.line_files import ARC_TOLERANCE, read_line

ezdxf = pytest.importorskip("ezdxf")

FIELD = "geometry.section.ground_m"
GROUND = [(20.0, 25.0), (30.0, 25.0), (50.0, 35.0), (70.0, 35.0)]


def _drawing(tmp_path, add, units=6):
    document = ezdxf.new()
    document.header["$INSUNITS"] = units
    add(document.modelspace())
    document.saveas(tmp_path / "section.dxf")
    return tmp_path / "section.dxf"


def _refusal(tmp_path, name) -> str:
    with pytest.raises(StudyError) as error:
        read_line(tmp_path, name, FIELD)
    assert error.value.field == FIELD
    return error.value.problem


def test_a_polyline_without_vertices_is_refused(tmp_path):
    _drawing(tmp_path, lambda space: space.add_polyline2d([], dxfattribs={"layer": "GROUND"}))
    assert "the POLYLINE on layer 'GROUND' has 0 vertices" in _refusal(tmp_path, "section.dxf#GROUND")


def test_a_truncated_drawing_is_refused_wherever_it_is_cut(tmp_path):
    text = _drawing(tmp_path, lambda space: space.add_lwpolyline(GROUND, dxfattribs={"layer": "GROUND"})).read_text()
    cut = tmp_path / "cut.dxf"
    for end in range(0, len(text), len(text) // 60):  # in the header (StopIteration in ezdxf) and after
        cut.write_text(text[:end])
        assert "cannot read cut.dxf as DXF" in _refusal(tmp_path, "cut.dxf#GROUND")


@pytest.mark.parametrize("layer", ['GR"OUND', "GROUND[", "a'b", "x=y", "GROUND or LINE"])
def test_a_layer_name_is_compared_not_parsed(tmp_path, layer):
    _drawing(tmp_path, lambda space: space.add_lwpolyline(GROUND, dxfattribs={"layer": "GROUND"}))
    assert f"no line on layer {layer!r}" in _refusal(tmp_path, f"section.dxf#{layer}")
    assert read_line(tmp_path, "section.dxf#ground", FIELD) == [list(p) for p in GROUND]  # as CAD: any case


def _on_circle(points, centre, radius_m):
    xy = np.array(points)
    return np.abs(np.hypot(xy[:, 0] - centre[0], xy[:, 1] - centre[1]) - radius_m)


@pytest.mark.parametrize("kind", ["LWPOLYLINE", "POLYLINE"])
@pytest.mark.parametrize("bulge", [1.0, -1.0, 0.2])
def test_arcs_are_read_within_the_stated_tolerance(tmp_path, kind, bulge):
    """A dished face: the arc from (30, 25) to (50, 35) with bulge b (b = 1: a half circle), drawn
    left to right.  Its points lie on the circle, and no chord is further than the tolerance from it."""
    vertices = [(20.0, 25.0, 0.0), (30.0, 25.0, bulge), (50.0, 35.0, 0.0), (70.0, 35.0, 0.0)]

    def add(space):
        if kind == "LWPOLYLINE":
            space.add_lwpolyline(vertices, format="xyb", dxfattribs={"layer": "GROUND"})
        else:
            line = space.add_polyline2d([v[:2] for v in vertices], dxfattribs={"layer": "GROUND"})
            line.vertices[1].dxf.bulge = bulge

    _drawing(tmp_path, add)
    points = read_line(tmp_path, "section.dxf#GROUND", FIELD)
    chord = math.dist((30.0, 25.0), (50.0, 35.0))
    theta = 4.0 * math.atan(bulge)
    radius_m = chord / (2.0 * math.sin(abs(theta) / 2.0))
    # the centre: on the chord's bisector, to the left of the chord for a counter-clockwise arc (b > 0)
    mid, normal = np.array([40.0, 30.0]), np.array([-10.0, 20.0]) / chord
    centre = mid + math.copysign(radius_m * math.cos(theta / 2.0), bulge) * normal
    arc = points[1:-1]
    assert arc[0] == [30.0, 25.0] and arc[-1] == [50.0, 35.0] and len(arc) > 4
    assert _on_circle(arc, centre, radius_m).max() < 1e-9 * radius_m
    size_m = max(np.ptp(np.array(points), axis=0))
    middles = (np.array(arc[1:]) + np.array(arc[:-1])) / 2.0
    assert _on_circle(middles, centre, radius_m).max() <= ARC_TOLERANCE * size_m
    # the arc's middle is where the bulge puts it: a sagitta of b c / 2 to the right of the chord for b > 0
    sagitta_m = abs(bulge) * chord / 2.0
    deepest = max(abs((x - 30.0) * 10.0 - (y - 25.0) * 20.0) / chord for x, y in arc)
    assert deepest == pytest.approx(sagitta_m, rel=1e-3)


@pytest.mark.parametrize("kind", ["LWPOLYLINE", "POLYLINE"])
def test_a_polyline_mirrored_in_cad_lands_where_it_is_drawn(tmp_path, kind):
    """Mirrored about the y axis in CAD, a polyline keeps its vertices and gets the extrusion
    (0, 0, -1): its object coordinates are (-x, y) of the world's."""
    mirrored = [(-x, y) for x, y in GROUND]
    attributes = {"layer": "GROUND", "extrusion": (0.0, 0.0, -1.0)}
    add = (lambda s: s.add_lwpolyline(mirrored, dxfattribs=attributes)) if kind == "LWPOLYLINE" else \
        (lambda s: s.add_polyline2d(mirrored, dxfattribs=attributes))
    _drawing(tmp_path, add)
    assert read_line(tmp_path, "section.dxf#GROUND", FIELD) == [list(p) for p in GROUND]


def test_a_drawing_in_other_units_is_refused_naming_them(tmp_path):
    _drawing(tmp_path, lambda s: s.add_lwpolyline([(1e3 * x, 1e3 * y) for x, y in GROUND],
                                                  dxfattribs={"layer": "GROUND"}), units=4)
    problem = _refusal(tmp_path, "section.dxf#GROUND")
    assert "drawn in millimeters ($INSUNITS = 4)" in problem and "metres" in problem
    _drawing(tmp_path, lambda s: s.add_lwpolyline(GROUND, dxfattribs={"layer": "GROUND"}), units=0)  # unitless
    assert read_line(tmp_path, "section.dxf#GROUND", FIELD) == [list(p) for p in GROUND]


@pytest.mark.parametrize("units", [25, 99, -1])
def test_a_unit_code_dxf_does_not_know_is_refused_as_such_not_as_unitless(tmp_path, units):
    """ezdxf names a code it does not know "unitless" (the name of 0, which is read as metres)."""
    _drawing(tmp_path, lambda s: s.add_lwpolyline(GROUND, dxfattribs={"layer": "GROUND"}), units=units)
    problem = _refusal(tmp_path, "section.dxf#GROUND")
    assert f"$INSUNITS = {units}, which is no unit of DXF" in problem and "unitless" not in problem


@pytest.mark.parametrize("row", ["1" * 200_000 + ",1", '"' + "a" * 200_000],
                         ids=["long number", "unclosed quote"])
def test_a_csv_field_longer_than_the_csv_module_reads_is_one_line(tmp_path, row):
    (tmp_path / "ground.csv").write_text(f"x,y\n0,0\n{row}\n5,5\n")
    problem = _refusal(tmp_path, "ground.csv")
    assert problem.startswith("ground.csv line 3: field larger than field limit") and len(problem) < 200


def test_a_long_row_that_is_not_a_point_is_quoted_short(tmp_path):
    (tmp_path / "ground.csv").write_text("x,y\n0,0\n" + "a" * 100_000 + ",1\n")
    problem = _refusal(tmp_path, "ground.csv")
    assert problem.startswith("ground.csv line 3: expected two numbers x, y") and len(problem) < 200
