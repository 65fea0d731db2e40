"""ACADS 1(c) four ways, run as a user runs them: its polygons, its lines, its lines from CSV files and
from a DXF file.  The FOS line each prints must be the same.

    python -m verification.section_forms            # 4 studies at h = 0.3 m on 2 local workers, about 80 s
    python -m verification.section_forms --spacing 0.5

The CSV and DXF forms are written from ``studies/published/acads_1c_lines.toml`` into a
temporary folder: one CSV file per line (x_m, y_m columns, three delimiters), and one DXF
drawing with the ground as an LWPOLYLINE drawn right to left, the layer lines as a POLYLINE and an
LWPOLYLINE on their own DXF layers, and a text on a fourth layer; the study names them as
``ground.csv`` or ``section.dxf#GROUND``.  Each study runs through the command line
(``spfem-fos STUDY --out DIR --quiet``) into a folder of its own.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

from workflows.study.toml_text import to_toml

PUBLISHED = Path(__file__).resolve().parents[1] / "studies" / "published"


def _csv(path: Path, points, delimiter: str) -> str:
    path.write_text("x_m" + delimiter + "y_m\n" + "".join(f"{x}{delimiter}{y}\n" for x, y in points))
    return path.name


def write_forms(folder: Path, spacing_m: float) -> dict[str, Path]:
    """The four study files of ACADS 1(c) at ``spacing_m``, written into ``folder``."""
    import ezdxf

    polygons = (PUBLISHED / "acads_1c.toml").read_text().replace("spacing_m = 0.3", f"spacing_m = {spacing_m}")
    lines = tomllib.loads((PUBLISHED / "acads_1c_lines.toml").read_text())
    lines["geometry"]["spacing_m"] = spacing_m
    section = lines["geometry"]["section"]
    ground, top_of_2, top_of_3 = section["ground_m"], section["layers"][0]["below_m"], section["layers"][0]["above_m"]
    forms = {"polygons": polygons, "lines": to_toml(lines)}

    section["ground_m"] = _csv(folder / "ground.csv", ground, ",")
    section["layers"][0]["below_m"] = section["layers"][1]["above_m"] = _csv(folder / "top_of_2.csv", top_of_2, ";")
    section["layers"][0]["above_m"] = _csv(folder / "top_of_3.csv", top_of_3, "\t")
    forms["lines from CSV"] = to_toml(lines)

    document = ezdxf.new()
    space = document.modelspace()
    space.add_lwpolyline(ground[::-1], dxfattribs={"layer": "GROUND"})
    space.add_polyline2d(top_of_2, dxfattribs={"layer": "TOP_OF_2"})
    space.add_lwpolyline(top_of_3, dxfattribs={"layer": "TOP_OF_3"})
    space.add_text("ACADS 1(c)", dxfattribs={"layer": "NOTES"})
    document.saveas(folder / "section.dxf")
    section["ground_m"] = "section.dxf#GROUND"
    section["layers"][0]["below_m"] = section["layers"][1]["above_m"] = "section.dxf#TOP_OF_2"
    section["layers"][0]["above_m"] = "section.dxf#TOP_OF_3"
    forms["lines from DXF"] = to_toml(lines)

    paths = {}
    for i, (label, text) in enumerate(forms.items()):
        paths[label] = folder / f"form_{i}.toml"
        paths[label].write_text(text)
    return paths


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m verification.section_forms", description=__doc__.splitlines()[0])
    parser.add_argument("--spacing", type=float, default=0.3, help="particle spacing h (m), default 0.3 as published")
    args = parser.parse_args(argv)
    fos_lines = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for label, study in write_forms(folder, args.spacing).items():
            start = time.perf_counter()
            done = subprocess.run([sys.executable, "-m", "workflows.cli", str(study), "--out", str(folder / study.stem),
                                   "--quiet"], capture_output=True, text=True)
            line = done.stdout.strip().splitlines()[-1] if done.stdout.strip() else done.stderr.strip()
            fos_lines[label] = line
            print(f"{label:>15}: exit {done.returncode}, {time.perf_counter() - start:5.1f} s: {line}", flush=True)
    same = len(set(fos_lines.values())) == 1
    print("the same FOS line from all four forms" if same else "the forms DIFFER")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
