"""How soon a probabilistic study of many realisations starts its first run, and what it has made by then.

    python -m verification.first_realisation                        # 100,000 realisations, this tree
    python -m verification.first_realisation --realisations 10      # the same study, ten realisations
    python -m verification.first_realisation --tree ../before       # another checkout

The quickstart (``studies/quickstart.toml``) with ``[probabilistic]`` of a lognormal cohesion of
COV 0.3 runs through the command as a user runs it (``python -m workflows.cli``, the tree's sources
first on ``PYTHONPATH``) into a scratch folder; the script waits for the first run file
(``OUT/cases/*/srf_*.nc``, written once that run has ended), interrupts the study (Ctrl-C: the same
command would resume it) and prints the seconds from the command's start to that file, the study
process's resident memory then, and the case folders made.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VARIABLE = ('\n[probabilistic]\nrealisations = {count}\n\n[[probabilistic.variables]]\n'
            'path = "materials.soil.cohesion_pa"\ndistribution = "lognormal"\ncov = 0.3\n')
POLL_S = 0.05


def first_realisation(tree: Path, count: int, limit_s: float) -> dict:
    """Run the study of ``count`` realisations with the sources of ``tree``: seconds to the first run
    file (None: none within ``limit_s``), resident MB of the study's process then, case folders made."""
    with tempfile.TemporaryDirectory() as scratch:
        study, out = Path(scratch) / "study.toml", Path(scratch) / "out"
        study.write_text((ROOT / "studies" / "quickstart.toml").read_text() + VARIABLE.format(count=count))
        start = time.perf_counter()
        process = subprocess.Popen([sys.executable, "-m", "workflows.cli", str(study), "--out", str(out), "--quiet"],
                                   cwd=scratch, env=dict(os.environ, PYTHONPATH=str(tree)),
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        first_s = None
        while process.poll() is None and time.perf_counter() - start < limit_s:
            if any(out.glob("cases/*/srf_*.nc")):
                first_s = time.perf_counter() - start
                break
            time.sleep(POLL_S)
        resident_mb = _resident_mb(process.pid)
        process.send_signal(signal.SIGINT)
        process.wait()
        made = sum(1 for _ in out.glob("cases/*/case.toml"))
    return {"first_run_file_s": first_s, "resident_mb": resident_mb, "case_folders": made}


def _resident_mb(pid: int) -> float | None:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--realisations", type=int, default=100_000)
    parser.add_argument("--tree", type=Path, default=ROOT, help="the checkout whose sources run the study")
    parser.add_argument("--limit", type=float, default=120.0, help="seconds to wait for the first run file")
    args = parser.parse_args()
    found = first_realisation(args.tree.resolve(), args.realisations, args.limit)
    first, resident = found["first_run_file_s"], found["resident_mb"]
    print(f"{args.realisations} realisations: "
          + (f"first run file after {first:.1f} s" if first is not None else f"no run file in {args.limit:g} s")
          + (f", {resident:.0f} MB resident then" if resident is not None else "")
          + f", {found['case_folders']} case folders made")


if __name__ == "__main__":
    main()
