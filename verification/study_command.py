"""Running a study text as a user does, for the verification and the benchmarks: ``python -m
workflows.cli`` in a folder of its own, quiet, timed as a whole command."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run_study_command(text: str, folder: Path) -> tuple[Path, float]:
    """Write ``text`` to ``folder/study.toml`` and run it into a fresh output folder; (that folder,
    wall time in s).  SystemExit with the command's stderr if it fails."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "study.toml").write_text(text)
    out = folder / f"out{time.monotonic_ns()}"
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "workflows.cli", str(folder / "study.toml"), "--out", str(out),
                           "--quiet"], cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{folder.name} failed:\n{done.stderr}")
    return out, time.perf_counter() - start
