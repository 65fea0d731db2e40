"""``OUT/report.html``: one self-contained page per study, to read in a browser and hand on.

The page holds, in order: the result as the command printed it (the FOS with its bracket, the
run table, the slip surface and its limit-equilibrium FOS; a sweep's table; pf with its
interval), the inputs (the section drawn as ``spfem-fos check`` draws it, then every table of the
study file as it was read, in SI units, each field under its own name and unit), every figure the
study drew in the output folder with its caption (:data:`FIGURE_CAPTIONS`), the code version and
the study file's text.  Pictures are embedded as base64 PNG (``data:`` addresses): the page needs
no other file, no script and no network.  It is written through a temporary file and a rename,
as every result file (``workflows.output.writing``).
"""

from __future__ import annotations

import base64
import dataclasses
import datetime
import fnmatch
import html
import io
from pathlib import Path

from spfem_core import __version__
from workflows.fields import Record, specs
from workflows.output.figures import drawn_by_us
from workflows.output.writing import write_bytes
from workflows.scene import scene_and_flow
from workflows.section_figure import draw_section
from workflows.study import Study

REPORT_FILE = "report.html"

FIGURE_CAPTIONS: tuple[tuple[str, str], ...] = (
    ("srf_curve.png", "Largest displacement at the end of each strength-reduction run against its strength "
                      "reduction factor (log scale): stable runs blue, failed red; the knee and the FOS with its "
                      "bracket marked."),
    ("slip_surface.png", "The slip surface of the first failed run: the sliding mass (the particles that moved "
                         "beyond the last stable run), the slip line under it with its entry and exit points, and "
                         "Spencer's limit-equilibrium FOS on that line."),
    ("fields_srf_*.png", "Equivalent plastic strain and displacement at the end of the runs either side of the "
                         "FOS (the last stable run and the first failed one)."),
    ("particle_spacing.png", "The particle spacing of a locally refined cloud."),
    ("convergence.png", "The FOS against the particle spacing h, with its band at each level and the Richardson "
                        "extrapolation to h = 0."),
    ("fos_time.png", "The factor of safety against time (each a strength-reduction search on the particles' pore "
                     "pressures and suction at that time, with its bracket), above the rain or the reservoir's level "
                     "that drove the transient flow."),
    ("fos_map.png", "The FOS over the two swept fields."),
    ("fos_*.png", "The FOS with its bracket against a swept field (a design chart)."),
    ("runout_*.png", "The runout against a swept field."),
    ("pf.png", "The probability of failure with its 95% interval against the swept field."),
    ("pf_convergence.png", "The estimate of the probability of failure and its 95% interval as the realisations "
                           "come in."),
    ("fos_distribution.png", "The distribution of the realisations' FOS: histogram and empirical cumulative "
                             "distribution, with the failure threshold dashed."),
    ("sensitivity.png", "Rank correlation of each random variable with the FOS."),
    ("form.png", "FORM: the FOS at each iteration's centre, the factor marked, and the sensitivity factors alpha at "
                 "the design point (beta, the FOSM index and the design point in the titles)."),
    ("point_estimate.png", "Point estimate method: the FOS at Rosenblueth's 2^n points (marker area: weight), the "
                           "estimated mean and +- one standard deviation, the factor marked."),
    ("subset_simulation.png", "Subset simulation: P(FOS < threshold) at each level's threshold down to pf at the "
                              "factor, and the FOS of every level's samples, the last level's failures in red."),
    ("slip_envelope.png", "The failed realisations' slip lines and their envelope."),
    ("failed_*.png", "A failed realisation: its random field and the plastic strain of its first failed run."),
    ("seepage.png", "The steady seepage solution: total head and flow."),
    ("threshold.png", "The threshold: for each value of the swept axis (a rain intensity), the time of the water at "
                      "which the FOS falls to 1, interpolated between the swept times."),
)
"""Caption of each figure a study draws in its output folder, by file-name pattern, in the order the
page shows them (the first matching pattern wins); any other picture of ours (a stage's final
state, named after the stage) follows with its name as caption."""

SECTION_CAPTION = ("The section as read: particles coloured by material, supports, walls, water and loads, "
                   "monitors and refined zones (as spfem-fos check draws it){}.")

HEADLINES = ("FOS ", "FOS=", "no FOS", "pf = ")
"""How the lines of the verdict start (``fos.report.verdict_line``, the probabilistic study's pf
line): the page shows them above the printed report, large."""

STYLE = """
body { font: 15px/1.45 system-ui, sans-serif; max-width: 1100px; margin: 2em auto; padding: 0 1em; color: #222; }
h1 { margin-bottom: 0.1em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.6em; }
.meta { color: #666; } pre { background: #f6f6f6; padding: 0.8em; white-space: pre-wrap; font-size: 13px; }
.headline { font-size: 18px; font-weight: 600; }
table { border-collapse: collapse; margin: 0.4em 0 1em; font-size: 13px; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.5em; text-align: left; vertical-align: top; }
th { background: #f0f0f0; } th .unit { font-weight: normal; color: #666; }
figure { margin: 1em 0 2em; } figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { color: #444; font-size: 14px; } nav a { margin-right: 1em; }
"""


def write_html_report(kind, outcome, study_file) -> Path:
    """Write ``OUT/report.html`` (module doc) of the study of ``kind`` (a ``workflows.cases.StudyType``)
    with ``outcome`` (what its ``conclude`` gave), read from ``study_file``; its path."""
    report = kind.report(outcome, False, study_file)
    page = report_page(kind.study, kind.out_dir, report.warnings + report.lines, label=kind.label,
                       base_note=kind.base_note)
    return write_bytes(page.encode("utf-8"), kind.out_dir / REPORT_FILE)


def report_page(study: Study, out_dir: Path, printed_lines: list[str], *, label: str, base_note: str = "") -> str:
    """The HTML text of the page (module doc) of a study of the type ``label`` says (``StudyType.label``;
    its section figure captioned with its ``base_note``)."""
    created = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    esc = html.escape
    parts = [
        "<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{esc(study.name)}: spfem-fos report</title>", f"<style>{STYLE}</style>", "</head>", "<body>",
        f"<h1>{esc(study.name)}</h1>",
    ]
    if study.study.description:
        parts.append(f"<p>{esc(study.study.description)}</p>")
    parts.append(f'<p class="meta">spfem-fos {esc(__version__)}; {esc(label)}; report made '
                 f"{created}; results in <code>{esc(str(out_dir))}</code></p>")
    parts.append('<nav><a href="#result">Result</a><a href="#inputs">Inputs</a><a href="#figures">Figures</a>'
                 '<a href="#study-file">Study file</a></nav>')
    parts += ['<section id="result">', "<h2>Result</h2>",
              *(f'<p class="headline">{esc(line)}</p>' for line in printed_lines if line.startswith(HEADLINES)),
              f"<pre>{esc(chr(10).join(printed_lines))}</pre>", "</section>"]
    parts += ['<section id="inputs">', "<h2>Inputs</h2>", *_section_figure(study, base_note), *_input_tables(study),
              "</section>"]
    figures = _result_figures(out_dir)
    parts += ['<section id="figures">', "<h2>Figures</h2>"]
    parts += [_figure(path.read_bytes(), caption, path.name) for path, caption in figures] or [
        "<p>No figure was drawn (<code>[output] figures = false</code>, or the study draws none).</p>"]
    parts.append("</section>")
    parts += ['<section id="study-file">', "<h2>Study file</h2>", f"<pre>{esc(study.source_text)}</pre>",
              "</section>", "</body>", "</html>", ""]
    return "\n".join(parts)


def _figure(png: bytes, caption: str, alt: str) -> str:
    """A ``<figure>`` with ``png`` embedded as a ``data:`` address."""
    data = base64.b64encode(png).decode("ascii")
    return (f'<figure><img src="data:image/png;base64,{data}" alt="{html.escape(alt)}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


def _section_figure(study: Study, base_note: str) -> list[str]:
    """The section drawing (``workflows.section_figure.draw_section``), unless the study draws no figures."""
    if not study.output.figures:
        return []

    buffer = io.BytesIO()
    scene, flow = scene_and_flow(study)
    draw_section(study, scene, buffer, flow=flow)
    return [_figure(buffer.getvalue(), SECTION_CAPTION.format(base_note), "section")]


def _result_figures(out_dir: Path) -> list[tuple[Path, str]]:
    """The pictures of ours in ``out_dir`` (not its case folders), in :data:`FIGURE_CAPTIONS` order."""
    found = [path for path in sorted(out_dir.glob("*.png")) if drawn_by_us(path)]
    ordered, seen = [], set()
    for pattern, caption in FIGURE_CAPTIONS:
        for path in found:
            if path.name not in seen and fnmatch.fnmatch(path.name, pattern):
                ordered.append((path, caption))
                seen.add(path.name)
    ordered += [(path, f"The final state of the stage {path.stem!r}.") for path in found if path.name not in seen]
    return ordered


# ---------------------------------------------------------------------------------------
# The study's tables, generated from their declarations (``workflows.fields``)
# ---------------------------------------------------------------------------------------

INPUT_TABLES = (("materials", "Materials"), ("probabilistic", "Probabilistic"), ("random_field", "Random field"),
                ("sweep", "Sweep"), ("refinement", "Refinement"), ("water", "Water"), ("seepage", "Seepage"),
                ("transient", "Transient water"),
                ("loads", "Loads"), ("boundary", "Supports"), ("walls", "Walls"), ("stages", "Stages"),
                ("solver", "Solver"), ("geometry", "Geometry"), ("monitors", "Monitors"))
"""The tables of :class:`Study` the page shows, in order, with their headings."""


def _input_tables(study: Study) -> list[str]:
    parts = []
    for name, heading in INPUT_TABLES:
        value = getattr(study, name)
        if value is None or value == ():
            continue
        parts.append(f"<h3>{heading}</h3>")
        if isinstance(value, tuple):
            parts.append(_entries_table(value))
        else:
            parts.append(_record_table(value))
    return parts


def _shown_fields(record: Record) -> list[tuple[str, object]]:
    """(name, value) of the fields of ``record`` that hold something (unset options left out)."""
    return [(name, getattr(record, name)) for name in specs(type(record))
            if getattr(record, name) is not None and getattr(record, name) != ()]


def _record_table(record: Record) -> str:
    """One table: a row per field (name with its unit, value, what it is); nested tables inside."""
    rows = []
    for name, value in _shown_fields(record):
        spec = specs(type(record))[name]
        rows.append(f"<tr><th>{html.escape(name)}{_unit(spec.unit)}</th><td>{_cell(value)}</td>"
                    f"<td>{html.escape(spec.doc.split(';')[0])}</td></tr>")
    return f"<table>{''.join(rows)}</table>"


def _entries_table(entries: tuple) -> str:
    """Entries of one array of tables (materials, supports, stages...) side by side: a column per
    entry (headed by its name), a row per field any of them sets."""
    rows: list[str] = []
    units: dict[str, str] = {}
    for entry in entries:
        for name, _ in _shown_fields(entry):
            if name not in units and name != "name":
                rows.append(name)
                units[name] = specs(type(entry))[name].unit
    kinds = [getattr(entry, "model", None) or getattr(entry, "kind", None) for entry in entries]
    head = "<tr><th></th>" + "".join(f"<th>{html.escape(str(getattr(entry, 'name', i)))}</th>"
                                     for i, entry in enumerate(entries)) + "</tr>"
    body = []
    if any(kinds):
        body.append("<tr><th>kind</th>" + "".join(f"<td>{html.escape(str(kind or ''))}</td>" for kind in kinds)
                    + "</tr>")
    for name in rows:
        body.append(f"<tr><th>{html.escape(name)}{_unit(units[name])}</th>"
                    + "".join(f"<td>{_cell(getattr(entry, name, None))}</td>" for entry in entries) + "</tr>")
    return f"<table>{head}{''.join(body)}</table>"


def _unit(unit: str) -> str:
    return f' <span class="unit">({html.escape(unit)})</span>' if unit and unit != "1" else ""


def _cell(value) -> str:
    """A value as the page shows it (numbers to 6 significant digits, polygons as their points)."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, Record):
        return _record_table(value)
    if isinstance(value, tuple):
        if value and all(isinstance(item, Record) for item in value):
            return _entries_table(value)
        return html.escape(_sequence(value))
    if dataclasses.is_dataclass(value):
        return html.escape(repr(value))
    return html.escape(str(value))


def _sequence(value: tuple) -> str:
    """A point, polygon or list of numbers as written in TOML, numbers to 6 significant digits."""
    if isinstance(value, tuple):
        return "[" + ", ".join(_sequence(item) for item in value) + "]"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)
