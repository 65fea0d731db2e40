"""The FOS protocol study: five published slopes, each strength-reduction protocol, against their references.

    python -m benchmarks.fos_protocols                      # every case and protocol (about 20 min on 2 cores)
    python -m benchmarks.fos_protocols --cases acads_1a --protocols quasi_static
    python -m benchmarks.fos_protocols --flow-rules associated as_declared

Each case is a shipped study file run by the command (``python -m workflows.cli``, 2 local
workers, warm numba cache) with its ``strength_reduction`` stage set to the protocol and flow
rule; the FOS, its bracket, whether the two criteria agree, the runs made and the wall time
come from ``summary.nc``.  Error = FOS / reference - 1.  The references and their sources are
in each study file's header and in docs/verification.md.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import xarray as xr

from workflows.stages.protocols import PROTOCOLS as PROTOCOL_KINDS

ROOT = Path(__file__).resolve().parents[1]

CASES = {
    # name: (study file, reference FOS, what the reference is)
    "reference_slope": ("studies/reference_slope.toml", 1.368, "limit equilibrium 1.366-1.369, upper bound 1.368"),
    "griffiths_lane_ex4": ("studies/published/griffiths_lane_ex4.toml", 1.472, "upper bound (least circle), phi = 0"),
    "acads_1a": ("studies/published/acads_1a.toml", 0.986, "Spencer (Bishop 0.987, referee 1.00)"),
    "acads_1c": ("studies/published/acads_1c.toml", 1.375, "Spencer (Morgenstern-Price 1.382, referee 1.39)"),
    "verruijt_slope": ("studies/published/verruijt_slope.toml", 1.534, "Bishop (PLAXIS 1.54, upper bound 1.542)"),
}
PROTOCOLS = tuple(PROTOCOL_KINDS)


def study_text(case: str, protocol: str, flow_rule: str, spacing_scale: float = 1.0) -> str:
    """The case's study file with the protocol and flow rule set in its strength-reduction stage,
    and its particle spacing multiplied by ``spacing_scale``."""
    text = (ROOT / CASES[case][0]).read_text()
    line = next(row for row in text.splitlines() if row.startswith("srf_step"))
    text = text.replace(line, f'{line}\nprotocol = "{protocol}"\nflow_rule = "{flow_rule}"', 1)
    spacing = next(row for row in text.splitlines() if row.startswith("spacing_m"))
    return text.replace(spacing, f"spacing_m = {float(spacing.split('=')[1]) * spacing_scale:.6g}", 1)


def run_case(case: str, protocol: str, flow_rule: str, scratch: Path, spacing_scale: float = 1.0) -> dict:
    folder = scratch / f"{case}_{protocol}_{flow_rule}_{spacing_scale:g}"
    folder.mkdir(parents=True)
    study = folder / "study.toml"
    study.write_text(study_text(case, protocol, flow_rule, spacing_scale))
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "workflows.cli", str(study), "--out", str(folder / "out"), "--quiet"],
                          cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{case} {protocol} {flow_rule} failed:\n{done.stderr}")
    with xr.open_dataset(folder / "out" / "summary.nc") as summary:
        fos = summary["fos"]
        status = summary["status"].values.astype(str)
        srf = summary["srf"].values
        failed = srf[status == "failed"]
        monotone = not (failed.size and (srf[(status == "stable") & (srf > failed.min())]).size)
        return dict(fos=float(fos), low=float(fos.attrs["fos_low"]), high=float(fos.attrs["fos_high"]),
                    agree=bool(fos.attrs["criteria_agree"]), monotone=monotone, runs=int(summary.sizes["srf"]),
                    particles=int(summary.attrs["n_particles"]), wall=wall)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.fos_protocols", description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", choices=sorted(CASES), default=list(CASES))
    parser.add_argument("--protocols", nargs="+", choices=PROTOCOLS, default=list(PROTOCOLS))
    parser.add_argument("--flow-rules", nargs="+", choices=("associated", "as_declared"), default=["associated"])
    parser.add_argument("--spacing-scale", type=float, nargs="+", default=[1.0],
                        help="multiply each study's particle spacing by these factors (convergence)")
    args = parser.parse_args(argv)
    subprocess.run([sys.executable, "-c", "from spfem_core.warmup import warm_up; warm_up()"], check=True, cwd=ROOT)
    print("| case | particles | protocol | flow rule | FOS [bracket] | reference | error | criteria agree | "
          "verdicts monotone | runs | wall (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as scratch:
        for case in args.cases:
            reference = CASES[case][1]
            for flow_rule, protocol, scale in [(f, p, k) for f in args.flow_rules for p in args.protocols
                                               for k in args.spacing_scale]:
                r = run_case(case, protocol, flow_rule, Path(scratch), scale)
                error = r["fos"] / reference - 1.0
                print(f"| {case} | {r['particles']:,} | {protocol} | {flow_rule} | {r['fos']:.4f} "
                      f"[{r['low']:.4f}, {r['high']:.4f}] | {reference:g} | {100 * error:+.1f}% | "
                      f"{'yes' if r['agree'] else 'NO'} | {'yes' if r['monotone'] else 'no'} | {r['runs']} | "
                      f"{r['wall']:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
