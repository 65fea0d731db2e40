"""A section drawn as lines (``[geometry.section]``, workflows.study.section_form) and its lines
read from CSV and DXF files (workflows.study.line_files): the published ACADS 1(c) slope written
both ways makes the scene of its polygon study, particle for particle, so the FOS is the same."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from verification.section_forms import write_forms
from workflows.scene import build_scene
from workflows.study import StudyError, load_study, parse_study
from workflows.study.toml_text import to_toml

PUBLISHED = Path(__file__).resolve().parents[1] / "studies" / "published"


def _same_scene(a, b):
    scene_a, scene_b = build_scene(a), build_scene(b)
    assert scene_a.n_particles == scene_b.n_particles > 1000
    np.testing.assert_array_equal(scene_a.node_xy_m, scene_b.node_xy_m)
    np.testing.assert_array_equal(scene_a.node_material, scene_b.node_material)
    np.testing.assert_array_equal(scene_a.node_fixed, scene_b.node_fixed)
    assert [m.name for m in a.materials] == [m.name for m in b.materials]


@pytest.fixture(scope="module")
def polygons():
    return load_study(PUBLISHED / "acads_1c.toml")


@pytest.fixture
def lines_raw():
    return tomllib.loads((PUBLISHED / "acads_1c_lines.toml").read_text())


def test_lines_make_the_polygon_study(polygons):
    lines = load_study(PUBLISHED / "acads_1c_lines.toml")
    _same_scene(polygons, lines)
    assert lines.stages == polygons.stages and lines.loads == polygons.loads


def test_lines_read_from_csv_files(tmp_path, polygons):
    study = load_study(write_forms(tmp_path, polygons.geometry.spacing_m)["lines from CSV"])
    _same_scene(polygons, study)
    # the study kept with the results holds the points, not the file names
    assert "ground.csv" not in study.source_text.split("\n", 1)[1]
    assert parse_study(study.source_text).geometry == study.geometry


def test_lines_read_from_a_dxf_file(tmp_path, polygons):
    pytest.importorskip("ezdxf")
    _same_scene(polygons, load_study(write_forms(tmp_path, polygons.geometry.spacing_m)["lines from DXF"]))


def _error(tmp_path, raw) -> StudyError:
    (tmp_path / "study.toml").write_text(to_toml(raw))
    with pytest.raises(StudyError) as error:
        load_study(tmp_path / "study.toml")
    return error.value


def test_line_file_errors_name_the_field(tmp_path, lines_raw):
    section = lines_raw["geometry"]["section"]
    section["ground_m"] = "missing.csv"
    assert "geometry.section.ground_m" in str(_error(tmp_path, lines_raw))
    assert "no such line file" in str(_error(tmp_path, lines_raw))
    (tmp_path / "ground.csv").write_text("x,y\n20,25\n30,25\n25,30\n")  # x turns back
    section["ground_m"] = "ground.csv"
    assert "geometry.section.ground_m" in str(_error(tmp_path, lines_raw))
    (tmp_path / "ground.csv").write_text("x,y\n20,25\n30,abc\n")
    message = str(_error(tmp_path, lines_raw))
    assert "line 3" in message and "geometry.section.ground_m" in message
    section["ground_m"] = "ground.dxf"
    (tmp_path / "ground.dxf").write_text("not a dxf")
    assert "name the DXF layer" in str(_error(tmp_path, lines_raw))
    section["ground_m"] = "ground.dxf#GROUND"
    assert "cannot read ground.dxf as DXF" in str(_error(tmp_path, lines_raw))


def test_a_dxf_layer_needs_one_line(tmp_path, lines_raw):
    ezdxf = pytest.importorskip("ezdxf")
    document = ezdxf.new()
    document.modelspace().add_lwpolyline([(20, 25), (70, 35)], dxfattribs={"layer": "GROUND"})
    document.modelspace().add_lwpolyline([(20, 26), (70, 36)], dxfattribs={"layer": "GROUND"})
    document.saveas(tmp_path / "section.dxf")
    lines_raw["geometry"]["section"]["ground_m"] = "section.dxf#WATER"
    message = str(_error(tmp_path, lines_raw))
    assert "no line on layer 'WATER'" in message and "GROUND" in message
    lines_raw["geometry"]["section"]["ground_m"] = "section.dxf#GROUND"
    assert "2 lines on layer 'GROUND'" in str(_error(tmp_path, lines_raw))


@pytest.mark.parametrize(
    "change, field, words",
    [
        (lambda s: s.update(base_y_m=26.0), "geometry.section.base_y_m", "below the ground"),
        (lambda s: s["layers"][0].update(material="clay"), "geometry.section.layers[0].material", "no [[materials]]"),
        (lambda s: s["layers"][0].update(above_m=[[30.0, 30.0], [70.0, 30.0]]),
         "geometry.section.layers[0].below_m", "passes under above_m"),
        (lambda s: s["layers"][0].update(above_m=[[10.0, 24.0], [15.0, 24.0]]),
         "geometry.section.layers[0].below_m", "shares no x-range"),
        (lambda s: [s["layers"][0].pop("above_m"), s["layers"][0].pop("below_m")],
         "geometry.section.layers[0].above_m", "give above_m, below_m or both"),
        (lambda s: s.update(ground_m=[[20.0, 25.0], [20.0, 35.0]]), "geometry.section.ground_m", "x must increase"),
    ],
)
def test_section_errors_name_the_field(lines_raw, change, field, words):
    change(lines_raw["geometry"]["section"])
    with pytest.raises(StudyError) as error:
        parse_study(to_toml(lines_raw))
    assert error.value.field == field and words in str(error.value)


def test_a_section_with_polygon_or_region_is_refused(lines_raw, polygons):
    lines_raw["geometry"]["polygon_m"] = [list(p) for p in polygons.geometry.polygon_m]
    with pytest.raises(StudyError, match="not both") as error:
        parse_study(to_toml(lines_raw))
    assert error.value.field == "geometry.polygon_m"
    del lines_raw["geometry"]["polygon_m"]
    lines_raw["materials"][1]["region_m"] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]
    with pytest.raises(StudyError, match="not both"):
        parse_study(to_toml(lines_raw))


def test_own_supports_replace_the_default(lines_raw):
    lines_raw["boundary"] = [{"name": "base", "y_max_m": 20.0, "vx_m_s": 0.0, "vy_m_s": 0.0}]
    study = parse_study(to_toml(lines_raw))
    assert [b.name for b in study.boundary] == ["base"]


@pytest.mark.parametrize("peak, refused", [
    ([[60.0, 35.0], [60.2, 135.0], [60.4, 35.0]], True),  # a survey's spike, 0.4 m wide at its foot
    ([[60.0, 35.0], [60.2, 39.0], [60.4, 35.0]], True),  # 4 m high: too small to count in the slope's height
    ([[60.0, 35.0], [60.001, 45.0], [60.2, 45.0], [60.201, 35.0]], True),  # a wall 0.2 m thick
    ([[58.0, 35.0], [60.0, 37.0], [62.0, 35.0]], False),  # a 1:1 ridge: as wide as high
])
def test_a_ground_peak_narrower_than_the_spacing_is_refused_naming_the_ground(lines_raw, peak, refused):
    """A spike no particle can fill used to set the slope's height (and so the response time, which
    refused stages[1].duration_s, or silently the failure displacement): it is the ground line's."""
    section = lines_raw["geometry"]["section"]
    section["ground_m"] = section["ground_m"][:3] + peak + [[70.0, 35.0]]
    lines_raw["geometry"]["spacing_m"] = 1.0
    if not refused:
        assert parse_study(to_toml(lines_raw)).slope_height_m == 12.0
        return
    words = r"the peak at \(60[0-9.]*, [0-9.]+\) m is narrower than the particle spacing 1 m"
    with pytest.raises(StudyError, match=words) as error:
        parse_study(to_toml(lines_raw))
    assert error.value.field == "geometry.section.ground_m"


def test_a_peak_in_a_refined_zone_is_measured_at_the_zone_spacing(lines_raw, polygons):
    """A polygon's spike names geometry.polygon_m; a refined zone fine enough to fill it accepts it."""
    raw = tomllib.loads((PUBLISHED / "acads_1c.toml").read_text())
    ground = [[70.0, 35.0], [60.4, 35.0], [60.3, 37.0], [60.1, 37.0], [60.0, 35.0]]  # a 0.2 m wide top
    polygon = raw["geometry"]["polygon_m"]
    at = polygon.index([70.0, 35.0])
    raw["geometry"]["polygon_m"] = polygon[:at] + ground + polygon[at + 1:]
    with pytest.raises(StudyError, match="narrower than the particle spacing 0.3 m") as error:
        parse_study(to_toml(raw))
    assert error.value.field == "geometry.polygon_m"
    zone = [[59.0, 34.0], [61.0, 34.0], [61.0, 38.0], [59.0, 38.0]]
    raw["geometry"]["refined"] = [{"name": "spike", "region_m": zone, "spacing_m": 0.05}]
    assert parse_study(to_toml(raw)).geometry.refined[0].spacing_m == 0.05


UPPER = [[30.0, 25.0], [40.0, 27.0], [50.0, 29.0], [54.0, 31.0], [70.0, 31.0]]


@pytest.mark.parametrize("layer, region", [
    # a lens pinching out at x = 60 whose lines run on together to the right side, and from 30 to 40
    ({"below_m": UPPER, "above_m": [[30.0, 25.0], [40.0, 27.0], [52.0, 24.0], [60.0, 31.0], [70.0, 31.0]]},
     [(40.0, 27.0), (50.0, 29.0), (54.0, 31.0), (60.0, 31.0), (52.0, 24.0)]),
    # a lens whose lines meet at both ends
    ({"below_m": [[35.0, 26.0], [45.0, 29.0], [55.0, 31.0]], "above_m": [[35.0, 26.0], [45.0, 25.0], [55.0, 31.0]]},
     [(35.0, 26.0), (45.0, 29.0), (55.0, 31.0), (45.0, 25.0)]),
    # a line dipping under the base (y = 20): the region closes below it
    ({"below_m": [[20.0, 24.0], [40.0, 15.0], [70.0, 24.0]]},
     [(20.0, 24.0), (40.0, 15.0), (70.0, 24.0), (70.0, 14.0), (20.0, 14.0)]),
    # and one above the ground's top (y = 35)
    ({"above_m": [[20.0, 24.0], [40.0, 40.0], [70.0, 24.0]]},
     [(20.0, 24.0), (40.0, 40.0), (70.0, 24.0), (70.0, 41.0), (20.0, 41.0)]),
])
def test_lines_that_meet_or_leave_the_section_make_the_region_they_draw(lines_raw, layer, region):
    """These were refused as a self-crossing materials[1].region_m, a field the study never wrote."""
    lines_raw["geometry"]["section"]["layers"][0] = {"material": "soil_2", **layer}
    study = parse_study(to_toml(lines_raw))
    assert study.materials[1].region_m == tuple(region)
    assert (build_scene(study).node_material == 1).sum() > 10


@pytest.mark.parametrize("above_m, words", [
    ([[30.0, 25.0], [40.0, 24.0], [50.0, 29.0], [60.0, 28.0], [70.0, 31.0]], "meet at x = 50 m and part again"),
    (UPPER, "coincide wherever they share x"),
])
def test_lines_that_meet_and_part_again_are_refused_naming_the_layer(lines_raw, above_m, words):
    lines_raw["geometry"]["section"]["layers"][0].update(below_m=UPPER, above_m=above_m)
    with pytest.raises(StudyError, match=words) as error:
        parse_study(to_toml(lines_raw))
    assert error.value.field == "geometry.section.layers[0]"


def test_a_layer_that_places_no_particle_is_named_as_the_layer(lines_raw):
    lines_raw["geometry"]["section"]["layers"][0] = {"material": "soil_2", "below_m": [[20.0, 10.0], [70.0, 10.0]]}
    with pytest.raises(StudyError, match="'soil_2' holds no particle: its region lies outside") as error:
        build_scene(parse_study(to_toml(lines_raw)))
    assert error.value.field == "geometry.section.layers[0]"
