"""Golden fingerprint of two studies: proof that a change leaves the numbers alone.

    python -m verification.fingerprint --check     # run both studies, compare to the stored fingerprint
    python -m verification.fingerprint --update    # run both studies, store a new fingerprint

The studies are run through the command line (``python -m workflows.cli``), so the check sees
only what a user sees and works on any version of the code:

- ``studies/quickstart.toml`` (2 workers): every variable of ``summary.nc`` over the runs the search
  decided with (:func:`decided_rows`), the FOS and its brackets, and the particle stresses of
  ``gravity.nc``;
- ``studies/cantilever_beam.toml``: every time series of ``run.nc`` (monitor displacement,
  velocity and stress, energies, largest displacement).

Each array is stored as the SHA-256 of its float64 bytes (the bit-for-bit check, ``--check``)
and as up to 50 of its values (the tolerance check of :func:`compare`, which
``tests/test_fingerprint.py`` uses so that a machine whose compiler contracts differently
does not fail it).  A change that is meant to change the numbers stores a new fingerprint
with ``--update`` and says so in its commit message.  Timestamps and
wall times are left out.  The record times (``time``) are compared to 1e-12 relative even by
``--check``: the stage clock adds up the steps of each compiled call, whose length follows the
wall clock, so two runs of the same code can differ there in the last bits; and so is the SRF
curve's curvature, numpy's log10 and powers of the displacements, whose last bit changes between
numpy releases.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr

from workflows.fos.criterion import first_failed_sweep_srf
from workflows.study import parse_study

ROOT = Path(__file__).resolve().parents[1]
FINGERPRINT_PATH = Path(__file__).resolve().parent / "fingerprint.json"
STUDIES = {"quickstart": "studies/quickstart.toml", "cantilever_beam": "studies/cantilever_beam.toml"}
SAMPLES = 50
"""Values kept per array for the tolerance check (evenly spaced)."""

SUMMARY_VARIABLES = ("srf", "max_displacement", "final_kinetic_energy", "status", "stop_time", "n_steps", "curvature")
FOS_ATTRIBUTES = ("fos_low", "fos_high", "knee_srf", "status_fos_low", "status_fos_high", "criteria_agree")
BEAM_SKIP = {"wall_time"}
NOT_TO_THE_BIT = {"time": 1e-12, "curvature": 1e-12}
"""Arrays compared by their sampled values even by ``--check``, with this relative tolerance (module doc):
the curvature is numpy's log10 and powers of the bit-identical displacements, whose last bit differs
between numpy releases (2.4 against the one that stored it)."""


def _entry(values) -> dict:
    """Hash and samples of one array (strings: the text itself)."""
    array = np.asarray(values)
    if array.dtype.kind in "OUS":
        text = [str(v) for v in array.ravel()]
        return {"hash": hashlib.sha256("\n".join(text).encode()).hexdigest(), "values": text}
    data = np.ascontiguousarray(array, dtype=np.float64).ravel()
    pick = np.unique(np.linspace(0, data.size - 1, min(SAMPLES, data.size)).round().astype(int)) if data.size else []
    return {"hash": hashlib.sha256(data.tobytes()).hexdigest(), "values": [float(data[i]) for i in pick],
            "shape": list(array.shape)}


def _run(study: str, out: Path) -> None:
    command = [sys.executable, "-m", "workflows.cli", str(ROOT / study), "--out", str(out), "--quiet", "--force"]
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{study} failed (exit {done.returncode}):\n{done.stderr}")


def decided_rows(summary: xr.Dataset) -> np.ndarray:
    """The rows of ``summary.nc`` the search decided with: up to its first failed run on the sweep
    grid (``criterion.first_failed_sweep_srf``).  A sweep value above it may or may not finish before
    it is cancelled, depending on the load of the machine, so it may or may not be in the file (the
    FOS and the curvature never depend on it)."""
    stage = parse_study(summary.attrs["study"]).strength_reduction
    srf = summary["srf"].values
    return srf <= first_failed_sweep_srf(srf, summary["status"].values, stage.srf_min, stage.srf_step)


def quickstart_prints(out_dir: Path) -> dict:
    """The fingerprint of a quickstart result folder (``summary.nc``, the rows :func:`decided_rows`,
    and ``gravity.nc``)."""
    with xr.open_dataset(out_dir / "summary.nc") as summary:
        rows = decided_rows(summary)
        prints = {name: _entry(summary[name].values[rows]) for name in SUMMARY_VARIABLES}
        prints["fos"] = _entry([float(summary["fos"])] + [float(summary["fos"].attrs[a]) for a in FOS_ATTRIBUTES])
    with xr.open_dataset(out_dir / "gravity.nc") as gravity:
        for component in ("xx", "yy", "zz", "xy"):
            prints[f"gravity_particle_s{component}"] = _entry(gravity[f"particle_s{component}"].values)
    return prints


def beam_prints(out_dir: Path) -> dict:
    """The fingerprint of a cantilever-beam result folder (``run.nc``)."""
    with xr.open_dataset(out_dir / "run.nc") as run:
        return {
            name: _entry(run[name].values) for name in sorted(run.data_vars)
            if "time" in run[name].dims and name not in BEAM_SKIP
        } | {"time": _entry(run["time"].values)}


def measure(scratch: Path) -> dict:
    """Run both studies into ``scratch`` and fingerprint their results."""
    _run(STUDIES["quickstart"], scratch / "quickstart")
    _run(STUDIES["cantilever_beam"], scratch / "beam")
    return {"quickstart": quickstart_prints(scratch / "quickstart"), "cantilever_beam": beam_prints(scratch / "beam")}


def stored() -> dict:
    """The fingerprint stored in ``fingerprint.json``."""
    return json.loads(FINGERPRINT_PATH.read_text())


def compare(measured: dict, stored: dict, rtol: float = 0.0, atol: float = 0.0) -> list[str]:
    """Differences between two fingerprints: every array by hash when ``rtol`` and ``atol`` are 0,
    else by its stored values within the tolerances (strings always exactly)."""
    problems = []
    for study, arrays in stored.items():
        for name, expected in arrays.items():
            got = measured.get(study, {}).get(name)
            where = f"{study}: {name}"
            if got is None:
                problems.append(f"{where}: missing")
            elif (rtol == 0.0 and atol == 0.0 and name not in NOT_TO_THE_BIT) or "shape" not in expected:
                if got["hash"] != expected["hash"]:
                    problems.append(f"{where}: differs (first values {got['values'][:3]} against {expected['values'][:3]})")
            elif got.get("shape") != expected["shape"]:
                problems.append(f"{where}: shape {got.get('shape')} against {expected['shape']}")
            else:
                a, b = np.array(got["values"]), np.array(expected["values"])
                same_nan = np.isnan(a) == np.isnan(b)
                relative = max(rtol, NOT_TO_THE_BIT.get(name, 0.0))
                close = np.isclose(a, b, rtol=relative, atol=atol) | (np.isnan(a) & np.isnan(b))
                if not (same_nan.all() and close.all()):
                    i = int(np.flatnonzero(~close)[0])
                    problems.append(f"{where}: sample {i} is {a[i]!r}, stored {b[i]!r}")
    return problems


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m verification.fingerprint", description=__doc__.splitlines()[0])
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--check", action="store_true", help="compare bit for bit with the stored fingerprint")
    what.add_argument("--update", action="store_true", help="store the fingerprint of the code as it is")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as scratch:
        measured = measure(Path(scratch))
    if args.update:
        FINGERPRINT_PATH.write_text(json.dumps(measured, indent=1) + "\n")
        print(f"wrote {FINGERPRINT_PATH}")
        return 0
    problems = compare(measured, stored())
    for line in problems:
        print(line)
    n = sum(len(arrays) for arrays in measured.values())
    print(f"{n - len(problems)} of {n} arrays identical to the bit (record times and curvature to "
          f"{NOT_TO_THE_BIT['time']:g})")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
