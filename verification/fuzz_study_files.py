"""Fuzzing the command with mutated study files: every input ends cleanly, in one line at most.

    python -m verification.fuzz_study_files [--examples 300]

Small valid studies (an elastic block settling under gravity, a coarse slope whose
strength-reduction search makes a few short runs, a sweep of two cases over a slope made
by ``[geometry.slope]``, the slope with water and loads, a runout, and the slope drawn as lines
in engineers' units) are mutated by hypothesis: a value replaced
by another type, a huge, tiny, negative, zero, NaN or infinite number, a key removed,
renamed or written twice, bytes corrupted, the text saved as UTF-16 or Latin-1; or a value of
the right type against the study's own scales (``_semantic``: a vertex 1e-12-1e-3 m from
another, gravity turned or of 0 to 1e4 m/s2, durations from 1e-9 s, SRF tolerances and failure
displacements out of scale, a material region or water line off the domain, supports removed,
a section's layer lines crossing, above the ground or off the section, its base at the ground).  Each
mutant is run through the command in this process (``typer.testing.CliRunner``).  It must end
with exit 0 and complete result files (no ``*.tmp``), or with exit 2, one line on stderr that
starts with ``error:`` and nothing written, or, for a valid study whose numbers drive the
solver past its limits (a boundary pushed at tens of metres per second), with exit 1 and one
line saying the run diverged (after any warning lines the study's scene gave, such as water over
unponded ground), the finished stages' files complete; never a traceback (an
exception escaping the command) and never another exit code.  ``tests/test_fuzz_study_files.py`` runs a bounded number
of examples; this script prints the outcome counts of as many as asked.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
import tempfile
import tomllib
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from workflows.cli import app
from workflows.study.toml_text import to_toml

BLOCK = """\
[study]
name = "block"

[geometry]
polygon_m = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]
spacing_m = 0.25

[[materials]]
name = "soil"
model = "elastic"
density_kg_m3 = 2000.0
youngs_modulus_pa = 1e7
poisson_ratio = 0.3

[loads]
gravity_m_s2 = [0.0, -10.0]

[[boundary]]
name = "base"
y_max_m = 0.0
vx_m_s = 0.0
vy_m_s = 0.0

[[stages]]
name = "settle"
kind = "relaxation"
max_duration_s = 0.5
record_interval_s = 0.05

[[monitors]]
name = "top"
x_m = 1.0
y_m = 1.0
"""

SLOPE = """\
[study]
name = "slope"

[geometry]
polygon_m = [[0.0, 0.0], [30.0, 0.0], [30.0, 3.0], [20.0, 3.0], [10.0, 8.0], [0.0, 8.0]]
spacing_m = 1.0

[[materials]]
name = "soil"
model = "drucker_prager"
density_kg_m3 = 2000.0
youngs_modulus_pa = 1e8
poisson_ratio = 0.3
cohesion_pa = 10e3
friction_deg = 20.0

[loads]
gravity_m_s2 = [0.0, -10.0]

[[boundary]]
name = "base"
y_max_m = 0.0
vx_m_s = 0.0
vy_m_s = 0.0

[[boundary]]
name = "sides"
x_max_m = 0.0
vx_m_s = 0.0

[[stages]]
name = "gravity"
kind = "relaxation"
elastic = true
max_duration_s = 5.0
record_interval_s = 0.1

[[stages]]
name = "srf"
kind = "strength_reduction"
duration_s = 1.0
record_interval_s = 0.05
srf_min = 1.0
srf_max = 1.4
srf_step = 0.2
fos_tolerance = 0.1
max_runs = 4
"""

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

SECTION = (
    '[study]\nname = "section"\n\n[geometry]\nspacing_m = 1.0\n\n'
    "[geometry.section]\nground_m = [[0.0, 8.0], [10.0, 8.0], [20.0, 3.0], [30.0, 3.0]]\nbase_y_m = 0.0\n\n"
    '[[geometry.section.layers]]\nmaterial = "clay"\nbelow_m = [[0.0, 4.0], [30.0, 2.5]]\n'
    "above_m = [[0.0, 1.0], [30.0, 0.5]]\n\n"
    + SLOPE[SLOPE.index("[[materials]]"):SLOPE.index("[loads]")]
    .replace("density_kg_m3 = 2000.0", "unit_weight_kn_m3 = 20.0").replace("cohesion_pa = 10e3", "cohesion_kpa = 10.0")
    + '[[materials]]\nname = "clay"\nmodel = "tresca"\nunit_weight_kn_m3 = 19.0\nyoungs_modulus_mpa = 50.0\n'
    "poisson_ratio = 0.45\nundrained_shear_strength_kpa = 40.0\n\n"
    + SLOPE[SLOPE.index("[loads]"):SLOPE.index("[[boundary]]")]  # no supports: the section makes them
    + SLOPE[SLOPE.index("[[stages]]"):]
)
"""The slope drawn as lines ([geometry.section]) with a layer between two lines, in kPa, MPa and kN/m3."""

BASES = {"block": BLOCK, "slope": SLOPE, "sweep": SWEEP, "water": WATER, "runout": RUNOUT, "section": SECTION}

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


@st.composite
def mutated_study_file(draw) -> bytes:
    """One mutant of one of the base studies (module doc), as the bytes of a file."""
    base = draw(st.sampled_from(sorted(BASES)))
    text = BASES[base]
    data = tomllib.loads(text)
    kind = draw(st.sampled_from(["value", "value", "value", "remove", "rename", "duplicate", "bytes", "encoding",
                                 "semantic", "semantic", "unchanged"]))
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
    elif kind == "duplicate":
        line = draw(st.sampled_from([row for row in text.splitlines() if " = " in row]))
        text = text.replace(line, line + "\n" + line, 1)
    raw = text.encode("utf-8")
    if kind == "bytes":
        position = draw(st.integers(0, len(raw) - 1))
        raw = raw[:position] + bytes([draw(st.integers(0, 255))]) + raw[position + 1:]
    elif kind == "encoding":
        raw = text.replace('"soil"', '"sôil"').encode(draw(st.sampled_from(["utf-16", "latin-1", "utf-32"])))
    return raw


@dataclass
class Outcome:
    """How the command ended on one input."""

    exit_code: int
    stderr: str
    traceback: str = ""
    problems: list[str] = field(default_factory=list)


def run_command(raw: bytes, scratch: Path) -> Outcome:
    """Run ``spfem-fos`` in this process on a file with the bytes ``raw``; judge the result (module doc)."""
    study, out = scratch / "study.toml", scratch / "out"
    study.write_bytes(raw)
    result = CliRunner().invoke(app, [str(study), "--out", str(out), "--workers", "1", "--quiet"])
    outcome = Outcome(result.exit_code, result.stderr)
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        outcome.traceback = f"{type(result.exception).__name__}: {result.exception}"
        outcome.problems.append(f"an exception escaped the command: {outcome.traceback}")
    written = sorted(p.name for p in out.rglob("*")) if out.exists() else []
    lines = [line for line in result.stderr.splitlines() if line.strip()]
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
    else:
        outcome.problems.append(f"exit code {result.exit_code}: {lines[-1:] or outcome.traceback}")
    return outcome


def fuzz(max_examples: int, counts: Counter | None = None, derandomize: bool = True) -> Counter:
    """Run ``max_examples`` mutants (``derandomize``: the same ones every time); raise on the first
    that breaks a rule of the module doc.  Returns the count of each exit code."""
    counts = Counter() if counts is None else counts

    @settings(max_examples=max_examples, deadline=None, derandomize=derandomize, database=None,
              suppress_health_check=list(HealthCheck))
    @given(raw=mutated_study_file())
    def one(raw: bytes) -> None:
        with tempfile.TemporaryDirectory() as scratch:
            outcome = run_command(raw, Path(scratch))
        counts[f"exit {outcome.exit_code}"] += 1
        assert not outcome.problems, outcome.problems

    one()
    return counts


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m verification.fuzz_study_files", description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=300)
    parser.add_argument("--random", action="store_true", help="new mutants on every call (not the derandomized set)")
    args = parser.parse_args(argv)
    counts = fuzz(args.examples, derandomize=not args.random)
    print(f"{sum(counts.values())} inputs: " + ", ".join(f"{n} {what}" for what, n in sorted(counts.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
