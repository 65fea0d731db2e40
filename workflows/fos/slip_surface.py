"""The slip surface of a strength-reduction study: the failure mechanism of its first failed run
as a line on the section, and Spencer's limit-equilibrium FOS on that line.

**The mechanism.**  Where the run file keeps the plastic strain, the shear band: the plastic strain
the first failed run gained over the last stable run below it (its own where the two are alike), the
particles whose gain reaches ``BAND_FRACTION`` of the largest, in their initial positions.  The band
is the mechanism whatever its shape and the cloud's grading: a shallow face slide on a steep slope,
where the displacements of two runs either side of the FOS differ little and everywhere, or a band
through a refined zone.  Without plastic strain (a synthetic field), the displacement of the failed
run minus that of the stable run, du_p = |u_p(failed) - u_p(stable)| per particle: the two classes of
log10 du that Otsu's threshold separates give the mass's typical displacement U (the median of the
upper class); the mass is the largest connected set of particles (neighbours closer than 1.5 h, h the
coarsest spacing) that moved more than U / 2, and the band its lower edge.

**The line.**  In columns two spacings of the band wide (the coarsest spacing for a mass), the slip
point lies at the band's middle: the mean height of its particles weighted by their gain (for a
mass: midway between its lowest particle and the highest particle of the rest below it, h / 2 below
the mass where nothing lies below), smoothed over three columns; at both ends the line rises to the
ground at the band's outermost particle (+- h / 2).  Its upper end is the entry (the back scarp), the
lower the exit (the toe); the depth is the largest vertical distance below the ground, the area the
one between the ground and the line, the typical displacement U the median of the particles above
the line (beyond the stable run's).

**Limit equilibrium on it** (:mod:`workflows.fos.limit_equilibrium`): the mass above the line in
SLICES slices, each particle's mass spread over its width h along x, its weight and horizontal
body force from the runs' acceleration (gravity and the pseudo-static earthquake), the surface
loads on the ground, the pore pressure and the strength of the particle nearest each slice's base
midpoint, unreduced: its material model's own (``limit_equilibrium.material_strengths``: c', phi'
of Mohr-Coulomb and Drucker-Prager soils, peak values of softening ones; s_u and phi = 0 of Tresca
ones).  Spencer's FOS on the mechanism's line is a
cross-check of the strength reduction; where they differ by more than ``CROSS_CHECK_MARGIN`` the
report says the line may not be the mechanism.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr
from scipy import sparse
from scipy.spatial import cKDTree

from spfem_core.geometry import surface_height_m
from workflows.fos.limit_equilibrium import Slices, SpencerResult, material_strengths, spencer
from workflows.scene import surface_load_forces

SLICES = 100
"""Slices of the limit-equilibrium mass (Spencer's F changes by < 0.1% beyond 50 on a circle)."""

NEIGHBOUR_RADIUS = 1.5
"""Particles closer than this many spacings belong to one connected mass."""
BAND_FRACTION = 0.25
"""A particle is in the shear band when its plastic-strain gain reaches this fraction of the largest."""
MIN_BAND_PARTICLES = 10
"""A band of fewer particles gives no line (the displacement's mass is used instead)."""
CROSS_CHECK_MARGIN = 0.1
"""Spencer on the line and the strength-reduction FOS differ by more than this fraction: said."""


@dataclass(frozen=True)
class SlipSurface:
    """A slip line on the section, from entry to exit, with what it bounds."""

    x_m: np.ndarray  # the line, from the entry (upper end) to the exit
    y_m: np.ndarray
    depth_m: float  # largest vertical distance below the ground
    area_m2: float  # between the ground and the line
    srf: float  # the failed run it came from
    stable_srf: float  # the stable run subtracted (NaN: none)
    moved_m: float  # U: typical displacement of the mass in the failed run (beyond the stable run's)
    limit_equilibrium: SpencerResult

    @property
    def entry_m(self) -> tuple[float, float]:
        return float(self.x_m[0]), float(self.y_m[0])

    @property
    def exit_m(self) -> tuple[float, float]:
        return float(self.x_m[-1]), float(self.y_m[-1])


def _otsu_threshold(values: np.ndarray, bins: int = 128) -> float:
    """The threshold that maximises the between-class variance of ``values`` (Otsu, 1979)."""
    counts, edges = np.histogram(values, bins=bins)
    centres = 0.5 * (edges[1:] + edges[:-1])
    weight = np.cumsum(counts) / counts.sum()
    mean = np.cumsum(counts * centres) / counts.sum()
    with np.errstate(divide="ignore", invalid="ignore"):
        between = (mean[-1] * weight - mean) ** 2 / (weight * (1.0 - weight))
    return float(centres[np.nanargmax(between[:-1])])


def _largest_connected(xy: np.ndarray, members: np.ndarray, radius_m: float) -> np.ndarray:
    """The members (bool mask) of the largest set of ``members`` linked by distances < radius."""
    index = np.flatnonzero(members)
    pairs = cKDTree(xy[index]).query_pairs(radius_m, output_type="ndarray")
    graph = sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(index.size, index.size))
    _, labels = sparse.csgraph.connected_components(graph, directed=False)
    largest = np.zeros_like(members)
    largest[index[labels == np.bincount(labels).argmax()]] = True
    return largest


def moving_mass(xy0_m: np.ndarray, displacement_m: np.ndarray, spacing_m: float) -> tuple[np.ndarray, float]:
    """(the particles of the sliding mass, U) from the mechanism's displacements (module doc)."""
    moved = displacement_m > 0.0
    log_u = np.log10(displacement_m[moved])
    upper = log_u > _otsu_threshold(log_u)
    typical_m = float(np.median(displacement_m[moved][upper]))
    return _largest_connected(xy0_m, displacement_m > 0.5 * typical_m, NEIGHBOUR_RADIUS * spacing_m), typical_m


def slip_line(xy0_m: np.ndarray, mass: np.ndarray, spacing_m: float, polygon_m) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) of the line under ``mass``, from end to end on the ground, x increasing (module doc)."""
    x, y = xy0_m[:, 0], xy0_m[:, 1]
    low = max(x[mass].min() - 0.5 * spacing_m, x.min())  # within the section
    high = min(x[mass].max() + 0.5 * spacing_m, x.max())
    edges = np.linspace(low, high, max(2, int(np.ceil((high - low) / (2.0 * spacing_m)))) + 1)
    column = np.digitize(x, edges) - 1
    xs, ys = [], []
    for i in range(edges.size - 1):
        in_column = column == i
        if not (in_column & mass).any():
            continue
        bottom = y[in_column & mass].min()
        below = y[in_column & ~mass & (y < bottom)]
        xs.append(0.5 * (edges[i] + edges[i + 1]))
        ys.append(0.5 * (bottom + below.max()) if below.size else bottom - 0.5 * spacing_m)
    ys = np.maximum(np.array(ys), np.asarray(polygon_m, dtype=float)[:, 1].min())  # not below the domain
    if ys.size >= 3:
        ys[1:-1] = (ys[:-2] + ys[1:-1] + ys[2:]) / 3.0
    ground = surface_height_m(polygon_m, np.array([low, high]))
    return np.array([low, *xs, high]), np.array([ground[0], *ys, ground[1]])


def shear_band(failed: dict, stable: dict | None) -> tuple[np.ndarray, np.ndarray] | None:
    """(band mask, gain) of the module doc from the runs' plastic strain; None where the run file
    keeps none or the band is too small."""
    if "plastic_strain" not in failed:
        return None
    gain = failed["plastic_strain"] - (stable["plastic_strain"] if stable is not None and "plastic_strain" in stable
                                       else 0.0)
    top = float(np.max(gain)) if gain.size else 0.0
    if not top > 0.0 or np.count_nonzero(gain >= BAND_FRACTION * top) < MIN_BAND_PARTICLES:
        gain = failed["plastic_strain"]  # the two runs alike: the failed run's own band
        top = float(np.max(gain)) if gain.size else 0.0
    if not top > 0.0:
        return None
    band = gain >= BAND_FRACTION * top
    return (band, gain) if np.count_nonzero(band) >= MIN_BAND_PARTICLES else None


def band_line(xy0_m: np.ndarray, band: np.ndarray, gain: np.ndarray, spacing_m: np.ndarray,
              polygon_m) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) of the line through the middle of the ``band``, from end to end on the ground, x
    increasing (module doc)."""
    x, y = xy0_m[band, 0], xy0_m[band, 1]
    weight = gain[band]
    h = float(np.median(spacing_m[band]))
    low, high = max(x.min() - 0.5 * h, xy0_m[:, 0].min()), min(x.max() + 0.5 * h, xy0_m[:, 0].max())
    edges = np.linspace(low, high, max(2, int(np.ceil((high - low) / (2.0 * h)))) + 1)
    column = np.clip(np.digitize(x, edges) - 1, 0, edges.size - 2)
    totals = np.bincount(column, weights=weight, minlength=edges.size - 1)
    heights = np.bincount(column, weights=weight * y, minlength=edges.size - 1)
    filled = totals > 0.0
    xs = 0.5 * (edges[1:] + edges[:-1])[filled]
    ys = heights[filled] / totals[filled]
    ys = np.clip(ys, np.asarray(polygon_m, dtype=float)[:, 1].min(), surface_height_m(polygon_m, xs))
    if ys.size >= 3:
        ys[1:-1] = (ys[:-2] + ys[1:-1] + ys[2:]) / 3.0
    line_x, line_y = np.array([low, *xs, high]), np.array([np.nan, *ys, np.nan])
    ground = surface_height_m(polygon_m, line_x)
    line_y[0], line_y[-1] = ground[0], ground[-1]
    below = np.flatnonzero(ground - line_y > 0.1 * h)  # where the band runs along the ground, it has come out
    if below.size:
        first, last = max(below[0] - 1, 0), min(below[-1] + 1, line_x.size - 1)
        line_x, line_y, ground = line_x[first:last + 1], line_y[first:last + 1], ground[first:last + 1]
        line_y[0], line_y[-1] = ground[0], ground[-1]
    return line_x, line_y


def limit_equilibrium_slices(study, particles: dict, line_x_m, line_y_m) -> Slices | str:
    """The slices of the mass above the line (module doc); a reason string when there are none.
    ``particles``: initial x0, y0, mass (kg m-1), spacing (m), material (row), pore_pressure (Pa)."""
    x0, y0 = particles["x0"], particles["y0"]
    acceleration = study.loads.acceleration_m_s2(study.geometry.polygon_m, strength_reduction=True)
    upper, lower = (0, -1) if line_y_m[0] >= line_y_m[-1] else (-1, 0)
    mirror = line_x_m[upper] > line_x_m[lower]  # the entry, the higher end, on the right: the mass moves to -x
    sign = -1.0 if mirror else 1.0
    px, lx = sign * x0, sign * np.asarray(line_x_m)
    ly = np.asarray(line_y_m)
    order = np.argsort(lx)
    lx, ly = lx[order], ly[order]
    edges = np.linspace(lx[0], lx[-1], SLICES + 1)
    base = np.interp(edges, lx, ly)
    middle = 0.5 * (edges[1:] + edges[:-1])
    width = np.diff(edges)
    above = (y0 > np.interp(px, lx, ly)) & (px > lx[0] - particles["spacing"]) & (px < lx[-1] + particles["spacing"])
    # each particle's mass spread evenly over [x - h/2, x + h/2]: its share in each slice
    half = 0.5 * particles["spacing"][above]
    share = np.clip(np.minimum(px[above, None] + half[:, None], edges[None, 1:])
                    - np.maximum(px[above, None] - half[:, None], edges[None, :-1]), 0.0, None) / (2.0 * half[:, None])
    mass = share * particles["mass"][above, None]
    slice_mass = mass.sum(axis=0)
    empty = ~(slice_mass > 0.0)  # a thin mass at coarse spacing: the nearest particle's density over the slice
    if empty.any():
        if np.all(empty):
            return "the mass above the line holds no particle"
        top = surface_height_m(study.geometry.polygon_m, sign * middle[empty])
        base_y = np.interp(middle[empty], lx, ly)
        near = cKDTree(np.column_stack([px, y0])).query(np.column_stack([middle[empty], 0.5 * (top + base_y)]))[1]
        density = particles["mass"][near] / particles["spacing"][near] ** 2
        slice_mass = slice_mass.copy()
        slice_mass[empty] = density * np.clip(top - base_y, 0.0, None) * width[empty]
        mass = np.concatenate([mass, np.diag(np.where(empty, slice_mass, 0.0))[empty]], axis=0)
        y0_slices = np.concatenate([y0[above], 0.5 * (top + base_y)])
    else:
        y0_slices = y0[above]
    if not (slice_mass > 0.0).all():
        return "a slice of the mass has no height"
    centroid_y = (mass * y0_slices[:, None]).sum(axis=0) / slice_mass
    vertical = -acceleration[1] * slice_mass
    if "load_y" in particles:  # the surface loads (N m-1) on the particles of the ground
        vertical = vertical - (share * particles["load_y"][above, None]).sum(axis=0)
    horizontal = sign * acceleration[0] * slice_mass
    base_y = np.interp(middle, lx, ly)
    nearest = cKDTree(np.column_stack([px, y0])).query(np.column_stack([middle, base_y]))[1]
    material = particles["material"][nearest]
    material_cohesion, material_tan_friction = material_strengths(study.materials)
    cohesion, tan_friction = material_cohesion[material], material_tan_friction[material]
    if not np.all(np.isfinite(cohesion)):
        names = sorted({study.materials[m].name for m in material[~np.isfinite(cohesion)]})
        return f"the slip line runs through {', '.join(names)}, which has no strength (elastic)"
    return Slices(x_m=middle, y_m=base_y, width_m=width, alpha_rad=np.arctan(-np.diff(base) / width),
                  vertical_load_n=vertical, horizontal_load_n=horizontal, horizontal_arm_m=centroid_y - base_y,
                  pore_pressure_pa=particles["pore_pressure"][nearest], cohesion_pa=cohesion, tan_friction=tan_friction)


def run_particles(path, study) -> dict | None:
    """The particle fields of a run file that :func:`slip_surface` reads; None: the file keeps none."""

    with xr.open_dataset(path) as ds:
        if "particle_x0" not in ds:
            return None
        fields = {"x0": "particle_x0", "y0": "particle_y0", "ux": "particle_ux", "uy": "particle_uy",
                  "mass": "particle_mass", "material": "particle_material", "pore_pressure": "particle_pore_pressure",
                  "plastic_strain": "particle_plastic_strain"}
        particles = {key: ds[name].values for key, name in fields.items() if name in ds}
        spacing = ds["particle_spacing"].values if "particle_spacing" in ds else None
    particles.setdefault("pore_pressure", np.zeros_like(particles["x0"]))
    particles["material"] = particles["material"].astype(np.int64)
    particles["spacing"] = spacing if spacing is not None else np.full(particles["x0"].size, study.geometry.spacing_m)
    if study.loads.surface_loads():
        xy0 = np.column_stack([particles["x0"], particles["y0"]])
        particles["load_y"] = surface_load_forces(study, xy0, particles["spacing"])[:, 1]
    return particles


def slip_surface(study, failed: dict, stable: dict | None, failed_srf: float, stable_srf: float,
                 limit_equilibrium: bool = True) -> SlipSurface | str:
    """The slip surface of ``study`` from the particle fields of its first failed run and of the last
    stable run below it (dicts of arrays: x0, y0, ux, uy, mass, spacing, material, pore_pressure); a
    reason string when there is none."""
    xy0 = np.column_stack([failed["x0"], failed["y0"]])
    ux, uy = failed["ux"], failed["uy"]
    if stable is not None:
        ux, uy = ux - stable["ux"], uy - stable["uy"]
    displacement = np.hypot(ux, uy)
    spacing = np.asarray(failed["spacing"], dtype=float)
    band = shear_band(failed, stable)
    if band is not None:
        x, y = band_line(xy0, *band, spacing, study.geometry.polygon_m)
        above = (xy0[:, 1] > np.interp(xy0[:, 0], x, y)) & (xy0[:, 0] >= x[0]) & (xy0[:, 0] <= x[-1])
        typical = float(np.median(displacement[above])) if above.any() else float(np.max(displacement))
    else:
        if np.count_nonzero(displacement > 0.0) < 10:
            return "the failed run moved no particle"
        mass, typical = moving_mass(xy0, displacement, float(np.max(spacing)))
        if mass.sum() < 10:
            return f"the mechanism holds {mass.sum()} particles: too few to draw a line"
        x, y = slip_line(xy0, mass, float(np.max(spacing)), study.geometry.polygon_m)
    if y[-1] > y[0]:
        x, y = x[::-1], y[::-1]  # from the entry, the upper end
    ground = surface_height_m(study.geometry.polygon_m, np.linspace(x.min(), x.max(), 400))
    line = np.interp(np.linspace(x.min(), x.max(), 400), x[np.argsort(x)], y[np.argsort(x)])
    slices = limit_equilibrium_slices(study, failed if stable is None else stable, x, y) if limit_equilibrium \
        else "not computed"
    if isinstance(slices, str):
        le = SpencerResult(float("nan"), float("nan"), slices)
    elif study.random_field is not None:
        le = SpencerResult(float("nan"), float("nan"), "not computed: the soil varies from point to point")
    else:
        le = spencer(slices)
    return SlipSurface(x_m=x, y_m=y, depth_m=float(np.max(ground - line)),
                       area_m2=float(np.trapezoid(ground - line, np.linspace(x.min(), x.max(), 400))),
                       srf=failed_srf, stable_srf=stable_srf, moved_m=typical, limit_equilibrium=le)


ENVELOPE_POINTS = 200
"""Abscissae of the envelope of many slip lines."""


def envelope(lines: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(x, lowest y, highest y, number of lines) over the x-range of ``lines`` (each (x, y)): at
    each x the deepest and the shallowest of the lines that reach it (NaN where none does)."""
    low = min(float(np.min(x)) for x, _ in lines)
    high = max(float(np.max(x)) for x, _ in lines)
    grid = np.linspace(low, high, ENVELOPE_POINTS)
    heights = np.full((len(lines), grid.size), np.nan)
    for i, (x, y) in enumerate(lines):
        order = np.argsort(x)
        reach = (grid >= x[order][0]) & (grid <= x[order][-1])
        heights[i, reach] = np.interp(grid[reach], x[order], y[order])
    count = np.isfinite(heights).sum(axis=0)
    with np.errstate(all="ignore"):
        lower = np.where(count > 0, np.nanmin(np.where(np.isfinite(heights), heights, np.inf), axis=0), np.nan)
        upper = np.where(count > 0, np.nanmax(np.where(np.isfinite(heights), heights, -np.inf), axis=0), np.nan)
    return grid, lower, upper, count
