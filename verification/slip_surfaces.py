"""The slip surface and its limit-equilibrium FOS against the published critical surfaces.

    python -m verification.slip_surfaces [--out DIR]

Runs ``studies/reference_slope.toml`` (h = 0.3 m) and ``studies/published/acads_1c.toml`` (three
layers, h = 0.3 m) on 2 local workers (reusing the runs already in ``DIR``) and prints, per slope:
the strength-reduction FOS, the slip line's entry, exit and depth, Spencer's FOS on it, the
published limit-equilibrium FOS, and where the published critical circle is known (the reference
slope: through the toe, entering 2.5 m behind the crest, 0.25 m below toe level at its lowest,
method notes) Spencer's FOS on that circle with the same particle weights, a check of the
limit-equilibrium code against the published 1.366.  It also shows how the line's FOS moves
when the mass is taken at U/4 or 3U/4 instead of U/2 (``slip_surface.moving_mass``).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr
from scipy.optimize import brentq

from workflows.cases import RunOptions
from workflows.fos import slip_surface
from workflows.fos.limit_equilibrium import spencer
from workflows.fos.run_store import run_file_name
from workflows.study import load_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]

SLOPES = {
    "reference_slope": (REPO / "studies" / "reference_slope.toml", "Spencer 1.366, Bishop 1.368-1.369",
                        ((17.5, 15.0), (40.0, 5.0), 4.75)),
    "acads_1c": (REPO / "studies" / "published" / "acads_1c.toml", "Spencer 1.375, Morgenstern-Price 1.382", None),
}
"""Name: (study file, published limit-equilibrium FOS, the published critical circle as (entry,
exit, lowest y) or None where the references give no coordinates)."""


def circle_through(entry, exit_, lowest_y_m: float, n: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """The circular arc from ``entry`` to ``exit_`` whose lowest point is at ``lowest_y_m``."""
    (x1, y1), (x2, y2) = entry, exit_

    def centre_x(radius):  # centre at (xc, lowest + radius) equidistant from both ends
        yc = lowest_y_m + radius
        return x2 - np.sqrt(radius**2 - (y2 - yc) ** 2)

    radius = brentq(lambda r: np.hypot(x1 - centre_x(r), y1 - lowest_y_m - r) - r, 0.5 * abs(x2 - x1), 1e3)
    xc, yc = centre_x(radius), lowest_y_m + radius
    x = np.linspace(x1, x2, n)
    return x, yc - np.sqrt(np.maximum(radius**2 - (x - xc) ** 2, 0.0))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="folder for the studies' results (default: a temporary one)")
    args = parser.parse_args(argv)
    root = args.out or Path(tempfile.mkdtemp(prefix="slip_surfaces_"))
    for name, (path, published, critical) in SLOPES.items():
        study = load_study(path)
        out = root / name
        outcome = run_study(study, out, RunOptions(workers=2))
        summary = xr.load_dataset(out / "summary.nc")
        print(f"{name}: FOS {outcome.fos:.4g} [{outcome.fos_low:.4g}, {outcome.fos_high:.4g}] by strength reduction; "
              f"limit equilibrium published: {published}")
        slip = outcome.slip
        if isinstance(slip, str):
            print(f"  no slip surface: {slip}")
            continue
        print(f"  slip line of the run at SRF {slip.srf:g} beyond {slip.stable_srf:g}: entry ({slip.entry_m[0]:.2f}, "
              f"{slip.entry_m[1]:.2f}) m, exit ({slip.exit_m[0]:.2f}, {slip.exit_m[1]:.2f}) m, lowest y "
              f"{slip.y_m.min():.2f} m, depth {slip.depth_m:.2f} m, area {slip.area_m2:.1f} m2")
        print(f"  Spencer on the slip line: {float(summary['le_fos']):.4f} "
              f"(interslice angle {summary['le_fos'].attrs.get('interslice_angle_deg', np.nan):.1f} deg)")
        failed = slip_surface.run_particles(out / run_file_name(slip.srf), study)
        stable = slip_surface.run_particles(out / run_file_name(slip.stable_srf), study)
        xy0 = np.column_stack([failed["x0"], failed["y0"]])
        moved = np.hypot(failed["ux"] - stable["ux"], failed["uy"] - stable["uy"])
        spacing = float(failed["spacing"].min())
        for share in (0.25, 0.75):
            mass = slip_surface._largest_connected(xy0, moved > share * slip.moved_m, 1.5 * spacing)
            x, y = slip_surface.slip_line(xy0, mass, spacing, study.geometry.polygon_m)
            slices = slip_surface.limit_equilibrium_slices(study, stable, x, y)
            print(f"  the mass at {share:g} U instead of U/2: Spencer {spencer(slices).fos:.4f}")
        if critical is not None:
            x, y = circle_through(*critical)
            slices = slip_surface.limit_equilibrium_slices(study, stable, x, y)
            print(f"  Spencer on the published critical circle, the same particle weights: {spencer(slices).fos:.4f}")


if __name__ == "__main__":
    main()
