"""Lines of a study read from files: a line field given as a file name instead of [[x, y], ...].

    ground_m = "ground.csv"            # two columns x, y (m); a header row is skipped
    ground_m = "section.dxf#GROUND"    # the polyline on the DXF layer GROUND (ezdxf)

The lines that may come from files are the section's (``geometry.section.ground_m``, its layers'
``above_m`` and ``below_m``) and the water's (``water.phreatic_line_m``, a material's
``phreatic_line_m``).  A name is relative to the study file's folder.  The points are read in
when the study is loaded, and the study stored with the results is the one with its lines
written out (``study.toml_text.to_toml``): the results do not depend on files beside them, and the
workers never read them.  A line drawn from right to left in a DXF file is turned round; the
line checks (x increasing, at least 2 points) are the study's, naming the field.
"""

from __future__ import annotations

import csv
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
    points = []
    for number, row in enumerate(csv.reader(text.splitlines(), dialect), start=1):
        cells = [cell.strip() for cell in row if cell.strip()]
        if not cells:
            continue
        try:
            x, y = (float(cell) for cell in cells)
        except ValueError:
            if number == 1 and not points:
                continue  # a header
            raise StudyError(field, f"{path.name} line {number}: expected two numbers x, y, got {row}") from None
        points.append([x, y])
    if len(points) < 2:
        raise StudyError(field, f"{path.name}: a line needs at least 2 points, got {len(points)}")
    return points


def _dxf_line(path: Path, layer: str, field: str) -> list[list[float]]:
    """The one polyline (LWPOLYLINE, POLYLINE or LINE) on ``layer`` of a DXF file, left to right."""
    import ezdxf  # only for a study that reads a DXF file

    try:
        document = ezdxf.readfile(path)
    except (OSError, ezdxf.DXFError) as error:
        raise StudyError(field, f"cannot read {path.name} as DXF: {error}") from None
    lines = []
    for entity in document.modelspace().query(f'LWPOLYLINE POLYLINE LINE[layer=="{layer}"]'):
        if entity.dxftype() == "LINE":
            lines.append([list(entity.dxf.start)[:2], list(entity.dxf.end)[:2]])
        elif entity.dxftype() == "LWPOLYLINE":
            lines.append([[float(x), float(y)] for x, y in entity.get_points("xy")])
        else:
            lines.append([[float(v.dxf.location[0]), float(v.dxf.location[1])] for v in entity.vertices])
    if len(lines) != 1:
        known = sorted({entity.dxf.layer for entity in document.modelspace()})
        what = "no line" if not lines else f"{len(lines)} lines"
        raise StudyError(field, f"{path.name}: {what} on layer {layer!r}, one is needed (layers: {known})")
    points = [[float(x), float(y)] for x, y in lines[0]]
    return points[::-1] if points[-1][0] < points[0][0] else points
