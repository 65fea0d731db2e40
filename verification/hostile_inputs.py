"""Hostile but realistic inputs, each run through the command as a user would: exit code and the
first line it printed, in this tree and (``--compare``) another.

    python -m verification.hostile_inputs                      # this tree
    python -m verification.hostile_inputs --compare ../before  # and another checkout, side by side

Each case is the quickstart study (``studies/quickstart.toml``) with one change, or a misuse of
the command line, run in a fresh process (``python -m workflows.cli`` with the tree's sources first
on ``PYTHONPATH``, from a scratch folder) on a fresh output folder.
Printed: a markdown table of the case, then per tree the exit code and its line (the first
warning and the FOS line of a study that ran, else the first error line on stderr, else its
first line), and whether a traceback
appeared anywhere; for the user-file case, whether the user's files survived.  The cases are the findings of issue #29.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
QUICKSTART = (ROOT / "studies" / "quickstart.toml").read_text()


def edit(old: str, new: str, count: int = 1) -> str:
    assert old in QUICKSTART, old
    return QUICKSTART.replace(old, new, count)


NO_BOUNDARY = QUICKSTART[:QUICKSTART.index("[[boundary]]")] + QUICKSTART[QUICKSTART.index("[solver]"):]
WATER_LIGHT = edit("[loads]", "[water]\nphreatic_level_m = 8.0\n\n[loads]").replace(
    "density_kg_m3 = 2000.0", "density_kg_m3 = 2000.0\nsaturated_density_kg_m3 = 500.0", 1)
LENS_OUTSIDE = edit("[loads]", '[[materials]]\nname = "lens"\nmodel = "elastic"\ndensity_kg_m3 = 2000.0\n'
                    'youngs_modulus_pa = 1e8\npoisson_ratio = 0.3\nregion_m = [[100.0, 0.0], [110.0, 0.0], '
                    '[110.0, 5.0]]\n\n[loads]')



def shifted(offset_x_m: float) -> str:
    """The quickstart moved by ``offset_x_m`` along x: its polygon, supports and monitors."""
    text = QUICKSTART
    for x in ("60.0", "40.0", "20.0"):
        text = text.replace(f"[{x},", f"[{offset_x_m + float(x)!r},")
    text = text.replace("[0.0, 0.0]", f"[{offset_x_m!r}, 0.0]").replace("[0.0, 15.0]", f"[{offset_x_m!r}, 15.0]")
    text = text.replace("x_max_m = 0.0", f"x_max_m = {offset_x_m!r}").replace("x_min_m = 60.0", f"x_min_m = {offset_x_m + 60!r}")
    return text.replace("x_m = 20.0", f"x_m = {offset_x_m + 20.0!r}").replace("x_m = 40.0", f"x_m = {offset_x_m + 40.0!r}")


WALL_CUT = edit("[solver]", '[[walls]]\nname = "cut"\nstart_m = [10.0, 20.0]\nend_m = [10.0, -5.0]\n\n[solver]')
SWEEP_EMPTY_BOX = QUICKSTART + '\n[sweep]\n[[sweep.axes]]\npath = "boundary.base.y_max_m"\nvalues = [-10.0]\n'

CASES = [
    # (label, study text, extra command-line arguments, user files put in --out first)
    ("SRF tolerance = 1e-2", edit("fos_tolerance = 0.01", "fos_tolerance = 0.01\ntolerance = 1e-2"), [], []),
    ("SRF duration_s = 0.1 s (below the response time)", edit("duration_s = 5.0", "duration_s = 0.1"), [], []),
    ("srf 1 to 3, step 0.5", edit("srf_max = 2.0", "srf_max = 3.0").replace("srf_step = 0.1", "srf_step = 0.5"),
     [], []),
    ("no [[boundary]]", NO_BOUNDARY, [], []),
    ("SRF stage with boundary = []", edit("srf_step = 0.1", "srf_step = 0.1\nboundary = []"), [], []),
    ("rollers only (no vertical support)", edit("vy_m_s = 0.0\n", ""), [], []),
    ("gravity [0, 0], no load", edit("gravity_m_s2 = [0.0, -10.0]", "gravity_m_s2 = [0.0, 0.0]"), [], []),
    ("a material region outside the domain", LENS_OUTSIDE, [], []),
    ("displacement_floor_m = 1 m (default failure 0.05 m)",
     edit("srf_step = 0.1", "srf_step = 0.1\ndisplacement_floor_m = 1.0"), [], []),
    ("failure_displacement_m = 1e6 m", edit("srf_step = 0.1", "srf_step = 0.1\nfailure_displacement_m = 1e6"), [], []),
    ("saturated density 500 kg/m3 under water", WATER_LIGHT, [], []),
    ("study.name of 300 letters", edit('name = "quickstart"', f'name = "{"q" * 300}"'), [], []),
    ("stage named summary", edit('name = "gravity"', 'name = "summary"'), [], []),
    ("stage named srf_1.0000", edit('name = "gravity"', 'name = "srf_1.0000"'), [], []),
    ("user files srf_field_survey.nc, report.nc.tmp in --out", QUICKSTART, [],
     ["srf_field_survey.nc", "report.nc.tmp"]),
    ("--out with a 300-character folder name", QUICKSTART, ["--out", "o" * 300], []),
    ("--out \"\"", QUICKSTART, ["--out", ""], []),
    ("--workers 64 on this machine", QUICKSTART, ["--workers", "64"], []),
    ("--scheduler \"\"", QUICKSTART, ["--scheduler", ""], []),
    ("--scheduler with --workers", QUICKSTART, ["--scheduler", "tcp://127.0.0.1:1", "--workers", "2"], []),
    ("the quickstart moved by 1e7 m (survey coordinates)", shifted(1e7), [], []),
    ("the quickstart moved by 1e10 m", shifted(1e10), [], []),
    ("a wall through the soil", WALL_CUT, [], []),
    ("supports holding every particle", edit("y_max_m = 0.0", "y_max_m = 100.0"), [], []),
    ("a redundant vertex mid-face", edit("[40.0, 5.0], [20.0, 15.0]", "[40.0, 5.0], [37.25, 6.375], [20.0, 15.0]"),
     [], []),
    ("phreatic level 100 m, no pond", edit("[loads]", "[water]\nphreatic_level_m = 100.0\n\n[loads]"), [], []),
    ("a swept value that empties a support box", SWEEP_EMPTY_BOX, [], []),
    ("no study file argument", None, [], []),
    ("an unknown option", QUICKSTART, ["--bogus"], []),
]


def run_case(tree: Path, text: str | None, args: list[str], user_files: list[str]) -> tuple[int, str, bool, str]:
    """(exit code, first line, a traceback printed, user files kept) of one case in ``tree``."""
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        command = [sys.executable, "-m", "workflows.cli"]
        if text is not None:
            (folder / "study.toml").write_text(text)
            command.append(str(folder / "study.toml"))
        if "--out" not in args:
            command += ["--out", str(folder / "out")]
        for name in user_files:
            (folder / "out").mkdir(exist_ok=True)
            (folder / "out" / name).write_text("the user's")
        env = dict(os.environ, PYTHONPATH=str(tree))  # the tree's sources, run from the scratch folder
        done = subprocess.run(command + args, cwd=folder, env=env, capture_output=True, text=True, timeout=600)
        kept = ("yes" if all((folder / "out" / name).is_file() for name in user_files) else "NO") if user_files else ""
    lines = [line for line in done.stderr.splitlines() if line.strip() and "━" not in line]
    fos = [line for line in done.stdout.splitlines() if line.startswith(("FOS", "no FOS"))]
    warnings = [line for line in lines if line.startswith("warning")]
    errors = [line for line in lines if line.startswith("error")]  # past a progress bar's last line
    first = "; ".join(warnings[:1] + fos[-1:]) if done.returncode == 0 and fos else (errors + lines + [""])[0]
    traceback = "Traceback" in done.stderr or "Traceback" in done.stdout
    return done.returncode, first, traceback, kept


def cell(result) -> str:
    code, first, traceback, kept = result
    first = re.sub(r"/tmp/tmp\w+/", "", first)
    first = first if len(first) <= 150 else first[:147] + "..."
    extra = (" **traceback**" if traceback else "") + (f" (user files kept: {kept})" if kept else "")
    return f"{code}: {first.replace('|', '/')}{extra}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m verification.hostile_inputs", description=__doc__.splitlines()[0])
    parser.add_argument("--compare", type=Path, help="another checkout of spfem-fos, run on the same cases")
    args = parser.parse_args(argv)
    trees = [("before", args.compare.resolve())] if args.compare else []
    trees.append(("this tree", ROOT))
    print("| input | " + " | ".join(label for label, _ in trees) + " |")
    print("|---|" + "---|" * len(trees))
    for label, text, extra, user_files in CASES:
        results = [cell(run_case(tree, text, extra, user_files)) for _, tree in trees]
        print(f"| {label} | " + " | ".join(results) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
