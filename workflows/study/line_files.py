"""Lines of a study read from files: a line field given as a file name instead of [[x, y], ...].

    ground_m = "ground.csv"            # two columns x, y (m); a header row is skipped
    ground_m = "section.dxf#GROUND"    # the polyline on the DXF layer GROUND (ezdxf)

The lines that may come from files are the section's (``geometry.section.ground_m``, its layers'
``above_m`` and ``below_m``) and the water's (``water.phreatic_line_m``, a material's
``phreatic_line_m``), and the histories of ``[transient]`` (a rain's (t_h, mm_h), a reservoir's
(t_h, level_m)).  A name is relative to the study file's folder.  The points are read in
when the study is loaded, and the study stored with the results is the one with its lines
written out (``study.toml_text.to_toml``): the results do not depend on files beside them, and the
workers never read them.  A line drawn from right to left in a DXF file is turned round; the
line checks (x increasing, at least 2 points) are the study's, naming the field.

A DXF line is read as CAD draws it: in world coordinates (a polyline's object coordinate system
turned into them), its arcs (bulges) as chords within ``ARC_TOLERANCE`` of the arc, in metres (a
drawing in other units is refused, naming them).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

from workflows.fields import StudyError

DXF_LAYER_SEPARATOR = "#"


def line_fields(raw: dict):
    """(path for messages, the dict holding it, its key) of every line field that may name a file."""
    geometry = raw.get("geometry") if isinstance(raw.get("geometry"), dict) else {}
    section = geometry.get("section") if isinstance(geometry.get("section"), dict) else {}
    yield "geometry.section.ground_m", section, "ground_m"
    for i, layer in enumerate(section.get("layers", []) if isinstance(section.get("layers"), list) else []):
        for key in ("above_m", "below_m"):
            if isinstance(layer, dict):
                yield f"geometry.section.layers[{i}].{key}", layer, key
    water = raw.get("water") if isinstance(raw.get("water"), dict) else {}
    yield "water.phreatic_line_m", water, "phreatic_line_m"
    for i, material in enumerate(raw.get("materials", []) if isinstance(raw.get("materials"), list) else []):
        if isinstance(material, dict):
            yield f"materials[{i}].phreatic_line_m", material, "phreatic_line_m"
    transient = raw.get("transient") if isinstance(raw.get("transient"), dict) else {}
    for i, entry in enumerate(transient.get("boundary", []) if isinstance(transient.get("boundary"), list) else []):
        for key in ("rain_history_h_mm_h", "level_history_h_m"):  # (time, value) histories
            if isinstance(entry, dict):
                yield f"transient.boundary[{i}].{key}", entry, key


def read_line_files(raw: dict, folder: Path) -> list[str]:
    """Replace, in ``raw``, every line field that names a file by the file's points; the names read."""
    read = []
    for field, holder, key in list(line_fields(raw)):
        name = holder.get(key)
        if isinstance(name, str):
            holder[key] = read_line(folder, name, field)
            read.append(name)
    return read


def read_line(folder: Path, name: str, field: str) -> list[list[float]]:
    """The points of the line file ``name`` (module doc), StudyError on ``field`` if it cannot be read."""
    file_name, _, layer = name.partition(DXF_LAYER_SEPARATOR)
    path = folder / file_name
    if not path.is_file():
        raise StudyError(field, f"no such line file {path}")
    if path.suffix.lower() == ".dxf":
        if not layer:
            raise StudyError(field, f"name the DXF layer of the line: \"{file_name}{DXF_LAYER_SEPARATOR}LAYER\"")
        return _dxf_line(path, layer, field)
    if layer:
        raise StudyError(field, f"{file_name}: a layer ({DXF_LAYER_SEPARATOR}{layer}) is for a .dxf file")
    return _csv_line(path, field)


SHOWN_CHARACTERS = 60
"""At most this much of a row that is not a point is quoted in the message."""


def _shortened(text: str) -> str:
    return text if len(text) <= SHOWN_CHARACTERS else f"{text[:SHOWN_CHARACTERS]}... ({len(text)} characters)"


def _csv_line(path: Path, field: str) -> list[list[float]]:
    """Rows x, y of a CSV file (comma, semicolon or tab), a first row that is not numbers skipped."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as error:
        raise StudyError(field, f"cannot read {path}: {error}") from None
    try:
        dialect = csv.Sniffer().sniff(text[:2048], delimiters=",;\t")
    except csv.Error:
        dialect = csv.excel
    points: list[list[float]] = []
    reader = csv.reader(text.splitlines(), dialect)
    try:
        for number, row in enumerate(reader, start=1):
            cells = [cell.strip() for cell in row if cell.strip()]
            if not cells:
                continue
            try:
                x, y = (float(cell) for cell in cells)
            except ValueError:
                if number == 1 and not points:
                    continue  # a header
                raise StudyError(field, f"{path.name} line {number}: expected two numbers x, y, got "
                                 f"{_shortened(repr(row))}") from None
            points.append([x, y])
    except csv.Error as error:  # a row the csv module cannot split (a field longer than its limit)
        raise StudyError(field, f"{path.name} line {reader.line_num}: {error}") from None
    if len(points) < 2:
        raise StudyError(field, f"{path.name}: a line needs at least 2 points, got {len(points)}")
    return points


DXF_LINE_TYPES = ("LWPOLYLINE", "POLYLINE", "LINE")

ARC_TOLERANCE = 1e-4
"""An arc of a DXF polyline (a vertex's bulge) is read as chords whose sagitta (the largest
distance between a chord and its arc) is at most this fraction of the line's size, the larger
side of its bounding box, arcs included: 1 cm on a 100 m section, far below any particle spacing
a section of that size runs at."""

DXF_METRES = 6
"""``$INSUNITS`` of a drawing in metres; 0 (unitless) is read as metres too."""


def _read_dxf(path: Path, field: str):
    """The ezdxf document of ``path``; StudyError on ``field`` if it is not a DXF file ezdxf can read.

    Besides its ``DXFError`` (a bad structure), ezdxf's reader raises ``StopIteration`` when a
    file ends before its header does (a truncated file), and ``ValueError`` or ``OverflowError``
    when a number in it does not convert (``abc``, ``1e999`` where an integer belongs)."""
    import ezdxf  # only for a study that reads a DXF file

    try:
        return ezdxf.readfile(path)
    except StopIteration:
        raise StudyError(field, f"cannot read {path.name} as DXF: the file ends before its header does "
                         "(cut short?)") from None
    except (OSError, ezdxf.DXFError) as error:
        raise StudyError(field, f"cannot read {path.name} as DXF: {error}") from None
    except (ValueError, OverflowError) as error:  # a UnicodeDecodeError too
        raise StudyError(field, f"cannot read {path.name} as DXF: a value in it does not convert ({error})") from None


def _dxf_line(path: Path, layer: str, field: str) -> list[list[float]]:
    """The one polyline (LWPOLYLINE, POLYLINE or LINE) on ``layer`` of a DXF file (the layer's name
    compared without regard to case, as CAD does), in world coordinates (x, y), left to right, its
    arcs as chords (``ARC_TOLERANCE``).  A drawing in units other than metres is refused:
    ``$INSUNITS`` is often the template's rather than the drawing's, and a conversion would
    rescale such a section silently."""
    from ezdxf import units  # ezdxf: only for a study that reads a DXF file

    document = _read_dxf(path, field)
    code = document.header.get("$INSUNITS", 0)
    if code not in (0, DXF_METRES):
        try:
            name = units.InsertUnits(code).name.lower()  # not units.unit_name: "unitless" for a code it does not know
        except (ValueError, TypeError):
            raise StudyError(field, f"{path.name} has $INSUNITS = {code}, which is no unit of DXF: set its units to "
                             f"metres ($INSUNITS = {DXF_METRES}) if its numbers are metres") from None
        raise StudyError(field, f"{path.name} is drawn in {name} ($INSUNITS = {code}) and lines are read in metres: "
                         f"scale the drawing to metres and set its units to metres ($INSUNITS = {DXF_METRES}), or "
                         "only set its units if its numbers are metres already")
    entities = [entity for entity in document.modelspace() if entity.dxftype() in DXF_LINE_TYPES
                and entity.dxf.layer.casefold() == layer.casefold()]
    if len(entities) != 1:
        known = sorted({entity.dxf.layer for entity in document.modelspace()})
        what = "no line" if not entities else f"{len(entities)} lines"
        raise StudyError(field, f"{path.name}: {what} on layer {layer!r}, one is needed (layers: {known})")
    entity = entities[0]
    if entity.dxftype() == "POLYLINE" and (entity.is_polygon_mesh or entity.is_poly_face_mesh):
        raise StudyError(field, f"{path.name}: the POLYLINE on layer {layer!r} is a mesh, not a line")
    points = _world_points(entity)
    if len(points) < 2:
        raise StudyError(field, f"{path.name}: the {entity.dxftype()} on layer {layer!r} has {len(points)} "
                         "vertices; a line needs at least 2")
    return points[::-1] if points[-1][0] < points[0][0] else points


def _world_points(entity) -> list[list[float]]:
    """The points (x, y) of a LINE, LWPOLYLINE or POLYLINE in world coordinates: a 2D polyline's
    vertices and arcs are in its object coordinate system (OCS, set by its extrusion: (0, 0, -1)
    for one mirrored in CAD), turned into world coordinates; a 3D polyline's are in world
    coordinates already; the spline frame's control points of a spline-fit POLYLINE are skipped
    (the line is its fit vertices)."""
    from ezdxf.lldxf.const import VTX_SPLINE_FRAME_CONTROL_POINT  # ezdxf: only for a study that reads a DXF file
    from ezdxf.math import Vec3

    if entity.dxftype() == "LINE":
        return [[float(entity.dxf.start[0]), float(entity.dxf.start[1])],
                [float(entity.dxf.end[0]), float(entity.dxf.end[1])]]
    if entity.dxftype() == "LWPOLYLINE":
        vertices = [(float(x), float(y), float(b)) for x, y, b in entity.get_points("xyb")]
        closed, elevation = entity.closed, float(entity.dxf.elevation)
    else:
        kept = [v for v in entity.vertices if not v.dxf.flags & VTX_SPLINE_FRAME_CONTROL_POINT]
        if entity.is_3d_polyline:
            return [[float(v.dxf.location[0]), float(v.dxf.location[1])] for v in kept]
        vertices = [(float(v.dxf.location[0]), float(v.dxf.location[1]), float(v.dxf.bulge)) for v in kept]
        closed, elevation = entity.is_closed, float(Vec3(entity.dxf.elevation).z)
    if closed and vertices:
        vertices.append((*vertices[0][:2], 0.0))
    ocs = entity.ocs()
    return [[float(p.x), float(p.y)] for p in ocs.points_to_wcs(Vec3(x, y, elevation) for x, y in _with_arcs(vertices))]


def _with_arcs(vertices: list[tuple[float, float, float]]) -> list[tuple[float, float]]:
    """The points of a polyline of (x, y, bulge) vertices, each arc (a bulge b != 0 from its vertex
    to the next: an included angle of 4 atan b) as chords of sagitta at most ``ARC_TOLERANCE``
    times the line's size."""
    # ezdxf: only for a study that reads a DXF file
    from ezdxf.math import BoundingBox2d, ConstructionArc, Vec2, bulge_to_arc

    arcs = {}
    for i, ((x0, y0, bulge), (x1, y1, _)) in enumerate(zip(vertices, vertices[1:])):
        if bulge != 0.0 and (x0, y0) != (x1, y1):
            center, start_rad, end_rad, radius = bulge_to_arc(Vec2(x0, y0), Vec2(x1, y1), bulge)
            arcs[i] = ConstructionArc(center, radius, math.degrees(start_rad), math.degrees(end_rad))
    box = BoundingBox2d((x, y) for x, y, _ in vertices)
    for arc in arcs.values():
        box.extend(arc.bounding_box)
    sagitta = ARC_TOLERANCE * max(box.size.x, box.size.y) if box.has_data else 0.0
    points = []
    for i, (x, y, _) in enumerate(vertices):
        points.append((x, y))
        if i in arcs:
            chords = [(p.x, p.y) for p in arcs[i].flattening(sagitta)]
            if math.dist(chords[0], (x, y)) > math.dist(chords[-1], (x, y)):  # clockwise: drawn from its end
                chords = chords[::-1]
            points.extend(chords[1:-1])
    return points
