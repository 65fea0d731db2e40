"""Every variable and attribute of the result files, declared once.

Each declaration gives the name, the dimensions, the units (a CF/UDUNITS string: "m",
"m s-1", "J m-1", "kg m-1", "m2", "degree"; "1" for a dimensionless number or a label) and
the long name.  The datasets take their netCDF attributes from here (``STAGE_FILE["time"](values)``
gives the (dims, values, attrs) of an xarray variable) and ``docs/result-files.md`` is
generated from the same tables (:mod:`workflows.output.reference`).

Files:

- ``STAGE_FILE``: a stage's result (``run.nc``, ``<stage>.nc``, ``gravity.nc``, ``srf_<F>.nc``):
  monitor histories over ``time``, energies, the final particle state and its UGRID mesh;
- ``COLLAPSE_METRICS``: added to the last stage's file of a study with ``[metrics]``;
- ``SUMMARY_FILE``: ``summary.nc`` of a strength-reduction study, one row per SRF run and the FOS;
- ``SWEEP_FILE``: ``study.nc`` of a sweep, the FOS of every case over the sweep's dimensions
  (``SWEEP_DIMS`` stands for them: one per axis of a grid, or ``case`` for a zip).
"""

from __future__ import annotations

from dataclasses import dataclass

from spfem_core.energy_budget import ENERGY_COLUMNS


@dataclass(frozen=True)
class Variable:
    """One netCDF variable: name, dimensions, units (UDUNITS), long name."""

    name: str
    dims: tuple[str, ...]
    units: str
    long_name: str

    def attrs(self, **extra) -> dict:
        """The netCDF attributes: units, long_name and ``extra``."""
        return {"units": self.units, "long_name": self.long_name, **extra}

    def __call__(self, values, **extra) -> tuple:
        """(dims, values, attrs): what an xarray Dataset takes for a variable."""
        return self.dims, values, self.attrs(**extra)

    def over(self, dims: tuple[str, ...], values, **extra) -> tuple:
        """(dims, values, attrs) on the given dimensions (a variable declared over ``SWEEP_DIMS``)."""
        return tuple(dims), values, self.attrs(**extra)


@dataclass(frozen=True)
class Attribute:
    """One global (or variable) attribute: its name and what it holds."""

    name: str
    meaning: str


def _table(*variables: Variable) -> dict[str, Variable]:
    return {v.name: v for v in variables}


_ENERGY_LONG_NAMES = {
    "kinetic": "total kinetic energy per metre of out-of-plane thickness",
    "strain": "elastic strain energy per metre of thickness",
    "gravity_potential": "gravitational potential energy per metre of thickness, relative to the stage start",
    "damping_dissipated": "energy removed by local damping since the stage start, per metre of thickness",
    "stabilisation_dissipated": "energy removed by the stabilisation since the stage start, per metre of thickness",
    "plastic_dissipated": "energy dissipated by plastic flow since the stage start, per metre of thickness",
    "contact_dissipated": "kinetic energy removed by the rigid walls since the stage start, per metre of thickness",
    "load_potential": "minus the work done on the soil by pore water, ponded water and surface loads since the "
                      "stage start, per metre of thickness",
}


def energy_variable_name(column: str) -> str:
    """The result variable of energy column ``column`` (``energy_budget.ENERGY_COLUMNS``)."""
    return "kinetic_energy" if column == "kinetic" else f"energy_{column}"


_MONITOR = ("monitor", "time")

STAGE_FILE = _table(
    Variable("time", ("time",), "s", "time since the start of the stage"),
    Variable("monitor", ("monitor",), "1", "monitor name, as given in the study"),
    Variable("monitor_particle", ("monitor",), "1",
             "index of the particle nearest to the monitor point, followed by the monitor"),
    Variable("monitor_x0", ("monitor",), "m", "initial x of the monitored particle"),
    Variable("monitor_y0", ("monitor",), "m", "initial y of the monitored particle"),
    Variable("monitor_ux", _MONITOR, "m", "x displacement of the monitored particle"),
    Variable("monitor_uy", _MONITOR, "m", "y displacement of the monitored particle"),
    Variable("monitor_vx", _MONITOR, "m s-1", "x velocity of the monitored particle"),
    Variable("monitor_vy", _MONITOR, "m s-1", "y velocity of the monitored particle"),
    Variable("monitor_sxx", _MONITOR, "Pa", "effective stress xx at the monitored particle (tension positive)"),
    Variable("monitor_syy", _MONITOR, "Pa", "effective stress yy at the monitored particle (tension positive)"),
    Variable("monitor_szz", _MONITOR, "Pa", "out-of-plane effective stress zz at the monitored particle"),
    Variable("monitor_sxy", _MONITOR, "Pa", "shear stress xy at the monitored particle"),
    *(Variable(energy_variable_name(c), ("time",), "J m-1", _ENERGY_LONG_NAMES[c]) for c in ENERGY_COLUMNS),
    Variable("max_displacement", ("time",), "m", "largest displacement magnitude of any particle"),
    Variable("max_speed", ("time",), "m s-1", "largest speed of any particle"),
    Variable("particle_x", ("particle",), "m", "x of the particle at the end of the stage"),
    Variable("particle_y", ("particle",), "m", "y of the particle at the end of the stage"),
    Variable("particle_ux", ("particle",), "m", "x displacement of the particle during the stage"),
    Variable("particle_uy", ("particle",), "m", "y displacement of the particle during the stage"),
    Variable("particle_vx", ("particle",), "m s-1", "x velocity of the particle at the end of the stage"),
    Variable("particle_vy", ("particle",), "m s-1", "y velocity of the particle at the end of the stage"),
    Variable("particle_sxx", ("particle",), "Pa", "effective stress xx at the particle (tension positive; the "
             "total stress is this minus particle_pore_pressure)"),
    Variable("particle_syy", ("particle",), "Pa", "effective stress yy at the particle (tension positive)"),
    Variable("particle_szz", ("particle",), "Pa", "out-of-plane effective stress zz at the particle"),
    Variable("particle_sxy", ("particle",), "Pa", "shear stress xy at the particle"),
    Variable("particle_x0", ("particle",), "m", "initial x of the particle"),
    Variable("particle_y0", ("particle",), "m", "initial y of the particle"),
    Variable("particle_plastic_strain", ("particle",), "1",
             "equivalent plastic strain, sum of sqrt(2/3 de_p:de_p) since the start"),
    Variable("particle_area", ("particle",), "m2", "smoothing-cell area of the particle on the final mesh"),
    Variable("particle_spacing", ("particle",), "m",
             "particle spacing h(x) the particle was made with (only with [[geometry.refined]] zones)"),
    Variable("particle_mass", ("particle",), "kg m-1", "particle mass per metre of thickness (fixed at the start)"),
    Variable("particle_pore_pressure", ("particle",), "Pa",
             "pore pressure u at the particle's final position (compression positive; 0 without [water])"),
    Variable("particle_material", ("particle",), "1",
             "material of the particle (row of [[materials]]; flag_meanings holds the names)"),
    Variable("mesh2d", (), "1", "triangle mesh of the particles at the end of the stage (UGRID mesh topology)"),
    Variable("mesh2d_face_nodes", ("face", "three"), "1",
             "particles at the corners of each triangle, counter-clockwise (start_index 0)"),
)

STAGE_FILE_ATTRIBUTES = (
    Attribute("study", "the full text of the study file that made the result"),
    Attribute("spfem_fos_version", "version of spfem-fos"),
    Attribute("created_utc", "when the file was written (UTC, ISO 8601)"),
    Attribute("study_name, stage_name, stage_kind, stage_index, n_stages", "which stage of which study"),
    Attribute("stage_<field>", "each setting of the stage, e.g. stage_duration_s"),
    Attribute("n_particles, n_steps, n_remesh", "particles, explicit steps and mesh rebuilds of the stage"),
    Attribute("wall_time_s", "wall time of the stage (s)"),
    Attribute("dt_s, critical_dt_s", "time step the stage took at its end (a relaxation: its own, the largest stable "
              "one, whatever solver.dt_s says) and the critical step of the last mesh at the particles' masses (s; a "
              "relaxation's density-scaled inertia steps above it, docs/method.md section 5)"),
    Attribute("converged, unbalanced_force_ratio", "relaxation stages: whether the tolerance was reached, and the "
              "ratio |f_unbalanced| / |m g| at the last step"),
    Attribute("note_<topic>", "what the run skipped or cut short, e.g. note_stabilisation = \"off (beta = 0): bond "
              "loop skipped\", note_early_stop"),
    Attribute("srf, status, status_reason, run_<scalar>", "SRF run files: the factor, the run's verdict and why, "
              "and its scalars as in summary.nc"),
    Attribute("gravity_key, run_key", "FOS studies: hashes of what shaped the gravity state and the run; a rerun "
              "reuses files whose key matches"),
    Attribute("particle_fields, run_fields", "SRF run files: 1 if the file holds the final particle state and its "
              "mesh (the particle and face variables), 0 if left out; the policy it was made under (all, failed or "
              "none: a probabilistic study's keep_fields); a rerun that keeps more makes the run again"),
)

COLLAPSE_METRICS = _table(
    Variable("final_wall_height_m", (), "m", "granular: height of the deposit at the wall (max y with x < h)"),
    Variable("runout_2mm_m", (), "m", "granular: runout, where the deposit first thins below 2 mm"),
    Variable("runout_5mm_m", (), "m", "granular: runout, where the deposit first thins below 5 mm"),
    Variable("runout_10mm_m", (), "m", "granular: runout, where the deposit first thins below 10 mm"),
    Variable("surface_rms_error_m", (), "m",
             "granular: RMS error of the final surface against the Bui et al. (2008) experiment"),
    Variable("surface_slope_deg", (), "degree", "granular: slope of the final surface over x = 0.02-0.20 m"),
    Variable("failure_line_angle_deg", (), "degree",
             "granular: angle from horizontal of the line between moved and unmoved material"),
    Variable("failure_line_base_x_m", (), "m", "granular: where that line meets the base"),
    Variable("back_scarp_x_m", (), "m", "cohesive: initial x of the back scarp (first moved particle on the top)"),
    Variable("crest_height_m", (), "m", "cohesive: height of the final crest"),
    Variable("toe_x_m", (), "m", "cohesive: toe, where the deposit thins below toe_thickness_m"),
    Variable("plastic_zone_area_m2", (), "m2",
             "cohesive: area of the particles whose plastic strain exceeds plastic_strain_threshold"),
    Variable("moved_threshold_m", (), "m", "a particle whose displacement exceeds this has moved"),
    Variable("plastic_strain_threshold", (), "1", "cohesive: plastic strain that counts as the plastic zone"),
    Variable("toe_thickness_m", (), "m", "cohesive: deposit thickness that defines the toe (2 h)"),
    Variable("surface_x", ("surface",), "m", "x of the free-surface point"),
    Variable("surface_height", ("surface",), "m", "free-surface height (upper envelope of the particles)"),
)

RUNOUT_METRICS = _table(
    Variable("runout_m", (), "m", "advance of the toe: the furthest point beyond the initial toe where the surface "
             "rose more than deposit_thickness_m"),
    Variable("retrogression_m", (), "m", "retreat of the scarp behind the initial crest: the point furthest back "
             "where the surface fell more than deposit_thickness_m"),
    Variable("sliding_mass_area_m2", (), "m2", "initial area of the particles that moved more than moved_threshold_m "
             "(per metre of thickness)"),
    Variable("max_speed_m_s", (), "m s-1", "largest particle speed recorded"),
    Variable("max_speed_time_s", (), "s", "stage time of the largest speed"),
    Variable("time_to_rest_s", (), "s", "start of the window over which the kinetic energy stayed below rest_fraction "
             "of the potential energy released (NaN: still moving at the end)"),
    Variable("potential_released_j_m", (), "J m-1", "gravity and load potential energy released by the end"),
    Variable("energy_budget_error", (), "1", "change of the sum of every energy column over the stage, as a fraction "
             "of the potential released"),
    Variable("deposit_thickness_m", (), "m", "surface change that counts for runout and retrogression"),
    Variable("moved_threshold_m", (), "m", "displacement above which a particle belongs to the sliding mass"),
    Variable("surface_x", ("surface",), "m", "x of the final surface point"),
    Variable("surface_height", ("surface",), "m", "final surface height (upper envelope of the particles)"),
)

SUMMARY_FILE = _table(
    Variable("srf", ("srf",), "1", "strength reduction factor F"),
    Variable("max_displacement", ("srf",), "m", "largest displacement of any particle during the run"),
    Variable("final_kinetic_energy", ("srf",), "J m-1", "kinetic energy at the end of the run, per metre of thickness"),
    Variable("status", ("srf",), "1", "verdict of the run: stable, failed or diverged"),
    Variable("status_reason", ("srf",), "1", "why the run got its verdict"),
    Variable("stop_time", ("srf",), "s", "simulated time reached (early stop: < duration)"),
    Variable("wall_time", ("srf",), "s", "wall time of the run on its worker"),
    Variable("run_start", ("srf",), "s",
             "wall clock when the run started on its worker, since the command started (NaN: reused run)"),
    Variable("run_end", ("srf",), "s",
             "wall clock when the run ended on its worker, since the command started (NaN: reused run)"),
    Variable("n_steps", ("srf",), "1", "explicit steps of the run"),
    Variable("curvature", ("srf",), "1",
             "curvature of the SRF-displacement curve (normalised axes, log10 displacement) over the runs up to the "
             "first failed sweep value; NaN at the ends and above it (runs there finish or not by timing)"),
    Variable("fos", (), "1",
             "factor of safety: middle of the bracket around the knee of the SRF-displacement curve (NaN: none)"),
    Variable("slip_x", ("slip_point",), "m", "x of the slip line, from its entry (upper end) to its exit, in the "
             "initial configuration (workflows/fos/slip_surface.py)"),
    Variable("slip_y", ("slip_point",), "m", "y of the slip line"),
    Variable("slip_srf", (), "1", "SRF of the failed run the slip line comes from (its mechanism: the displacement "
             "beyond the last stable run's, attribute stable_srf)"),
    Variable("slip_entry_x", (), "m", "x of the slip line's entry on the ground (its upper end, the back scarp)"),
    Variable("slip_entry_y", (), "m", "y of the slip line's entry"),
    Variable("slip_exit_x", (), "m", "x of the slip line's exit on the ground (its lower end, the toe)"),
    Variable("slip_exit_y", (), "m", "y of the slip line's exit"),
    Variable("slip_depth", (), "m", "largest vertical depth of the slip line below the ground"),
    Variable("slip_area", (), "m2", "area of the sliding mass: between the ground and the slip line"),
    Variable("le_fos", (), "1", "limit-equilibrium factor of safety on the slip line (Spencer), a cross-check: at "
             "least the critical surface's (NaN: none, attribute reason)"),
)

FOS_ATTRIBUTES = (
    Attribute("fos_low, fos_high", "the FOS bracket: the steepest rise of the displacement after the knee"),
    Attribute("knee_srf", "SRF of maximum curvature of the sweep"),
    Attribute("criterion", "how the FOS was found, or why there is none"),
    Attribute("second_criterion", "the runs' verdicts, the second criterion"),
    Attribute("status_fos_low, status_fos_high", "the bracket from the verdicts: highest stable and lowest failed SRF"),
    Attribute("criteria_agree", "1 when the two brackets overlap within fos_tolerance"),
    Attribute("verdict", "the report's one-line verdict"),
)

SUMMARY_FILE_ATTRIBUTES = (
    Attribute("study, spfem_fos_version, created_utc, study_name", "as in a stage file"),
    Attribute("n_particles", "particles of the slope"),
    Attribute("fos_tolerance, displacement_floor_m", "the search's tolerance and the floor of the log-scale curve"),
    Attribute("srf_stiffness_factor", "the SRF runs used every Young's modulus times this (1: as declared, as "
              "with scale_stiffness = false or a softening material; docs/method.md, section 9)"),
    Attribute("search_stop", "why the search stopped"),
    Attribute("srf_not_run, srf_not_run_reason", "SRF values the search skipped or cancelled, and why"),
    Attribute("gravity_reused", "1 when the gravity state came from an earlier invocation"),
    Attribute("runs_started_ahead, runs_started_ahead_used",
              "runs guessed on idle workers ahead of the search, and how many the search then asked for"),
    Attribute("time_<part>_s", "wall time of gravity, srf_runs_elapsed, srf_runs_worker (summed over workers), "
              "remeshing, io and total (s)"),
    Attribute("box_decides", "1 when the first failed run's mechanism reaches a side of the domain, a welded "
              "support or a smooth base: the FOS depends on where the box was drawn (workflows/fos/domain_edges.py)"),
    Attribute("mechanism_edges", "each support the mechanism reaches, what it is and what to do; empty: none"),
)

SWEEP_DIMS = ("<sweep dims>",)
"""The dimensions of a sweep: one per axis of a grid (named by the axis label, e.g. ``cohesion_pa``,
with the axis values as its coordinate), or ``case`` for a zip (each axis a coordinate over it)."""

SWEEP_FILE = _table(
    Variable("case_folder", SWEEP_DIMS, "1",
             "the folder under OUT/cases/ with the case's files (an identical case's, when two are the same)"),
    Variable("fos", SWEEP_DIMS, "1",
             "factor of safety of the case (NaN: none, see status; fos_low or fos_high may still bound it)"),
    Variable("fos_low", SWEEP_DIMS, "1",
             "lower end of the FOS bracket (above_srf_max: the highest stable SRF, the FOS is above it; no_knee: "
             "the highest stable SRF below the lowest failed one)"),
    Variable("fos_high", SWEEP_DIMS, "1",
             "upper end of the FOS bracket (below_srf_min: the lowest failed SRF, the FOS is below it; no_knee: "
             "the lowest failed SRF)"),
    Variable("status", SWEEP_DIMS, "1",
             "found (a FOS), above_srf_max (no run failed), below_srf_min (every run failed), no_knee (runs "
             "failed but the curve has no knee), gravity_diverged"),
    Variable("criteria_agree", SWEEP_DIMS, "1", "1 when the run verdicts bracket the same FOS (summary.nc)"),
    Variable("knee_srf", SWEEP_DIMS, "1", "SRF of maximum curvature of the case's sweep"),
    Variable("n_particles", SWEEP_DIMS, "1", "particles of the case's slope"),
)

REFINED_SWEEP_FILE = _table(
    Variable("fos_limit", SWEEP_DIMS, "1",
             "the case's FOS at h -> 0 (its refinement.nc; NaN: fewer than four levels have an FOS)"),
    Variable("fos_uncertainty", SWEEP_DIMS, "1", "U of the case: its FOS lies in fos_limit -+ U (95%)"),
    Variable("fos_band_low", SWEEP_DIMS, "1", "lower end of the case's discretisation band, fos_limit - U"),
    Variable("fos_band_high", SWEEP_DIMS, "1", "upper end of the case's discretisation band, fos_limit + U"),
    Variable("band_trusted", SWEEP_DIMS, "1", "1 when the case's band is trusted (as refinement.nc), else 0"),
    Variable("finest_spacing", SWEEP_DIMS, "m", "particle spacing of the case's finest level, whose FOS is fos"),
)
"""What ``study.nc`` of a sweep with ``[refinement]`` holds besides ``SWEEP_FILE``, whose variables
there are those of each case's finest level."""

PROBABILISTIC_FILE = _table(
    Variable("<variable>", ("realisation",), "<the field's unit>",
             "the value of each random variable drawn for the realisation (one variable per [[probabilistic."
             "variables]], named by its field; its path in the attribute sweep_path)"),
    Variable("verdict", ("realisation",), "1", "stable, failed, or undecided (gravity diverged, no verdict)"),
    Variable("status", ("realisation",), "1", "the realisation's status as in a sweep's study.nc"),
    Variable("fos", ("realisation",), "1", "its FOS (fos mode; NaN in verdict mode or where none)"),
    Variable("fos_low", ("realisation",), "1", "lower end of its FOS bracket, or the highest stable SRF"),
    Variable("fos_high", ("realisation",), "1", "upper end of its FOS bracket, or the lowest failed SRF"),
    Variable("case_folder", ("realisation",), "1", "the folder under OUT/cases/ with its files"),
    Variable("max_displacement", ("realisation",), "m",
             "verdict mode: the largest displacement of its run (which ends once past the failure displacement); "
             "NaN in fos mode"),
    Variable("n_runs", ("realisation",), "1", "its strength-reduction runs"),
    Variable("n_steps", ("realisation",), "1", "explicit steps of its runs"),
    Variable("run_wall_time", ("realisation",), "s", "wall time of its runs on their workers"),
    Variable("particle_fields", ("realisation",), "1",
             "1 if its run files keep the final particle state (keep_fields, keep_fields_first), else 0"),
    Variable("pf_running", ("realisation",), "1",
             "pf of the realisations up to and including this one (pf against the count)"),
    Variable("fos_rank_correlation", ("random_variable",), "1",
             "Spearman rank correlation of each random variable with the FOS (fos mode): the sensitivity"),
    Variable("form_iteration", ("realisation",), "1",
             "form: the iteration whose point it is (its centre, then a step along each variable); -1: a point of "
             "SORM's round"),
    Variable("design_point", ("random_variable",), "<the field's unit>",
             "form: each variable's value at the design point, u* = -beta alpha through the Nataf transform"),
    Variable("sensitivity_alpha", ("random_variable",), "1",
             "form: the sensitivity factors alpha = grad g / |grad g| at the last iteration (alpha^2 the variable's "
             "share; positive: its increase makes the slope safer)"),
    Variable("point_weight", ("realisation",), "1", "point_estimate: Rosenblueth's weight of the point"),
    Variable("subset_level", ("realisation",), "1",
             "subset_simulation: the level that made the point (0: the Monte Carlo sample; a later level's chains)"),
    Variable("subset_accepted", ("realisation",), "1",
             "subset_simulation: 1 if the point is a level's sample (level 0's, or a chain's accepted candidate)"),
    Variable("last_level_failed", ("realisation",), "1",
             "subset_simulation: 1 for the last level's samples below the factor (the conditional failure samples)"),
    Variable("threshold_fos", ("subset_threshold",), "1",
             "subset_simulation: each level's threshold FOS b_k (the last: the factor)"),
    Variable("threshold_pf", ("subset_threshold",), "1",
             "subset_simulation: P(FOS < threshold_fos): p0^k, and pf at the factor (pf against the threshold)"),
    Variable("slip_envelope_x", ("slip_envelope_point",), "m",
             "x of the envelope of the failed realisations' slip lines (of those whose run files keep the particles)"),
    Variable("slip_envelope_lower", ("slip_envelope_point",), "m", "the deepest of the slip lines at x"),
    Variable("slip_envelope_upper", ("slip_envelope_point",), "m", "the shallowest of the slip lines at x"),
    Variable("slip_envelope_count", ("slip_envelope_point",), "1", "how many of the slip lines reach x"),
)
"""``probabilistic.nc`` of a probabilistic study (``[probabilistic]``): every realisation over
the dimension ``realisation``, and the study's statistics as attributes."""

PROBABILISTIC_FILE_ATTRIBUTES = (
    Attribute("study, spfem_fos_version, created_utc, study_name", "as in a stage file (the study's text)"),
    Attribute("pf, pf_low, pf_high", "probability of failure (failed / decided) and its exact (Clopper-Pearson) "
              "95% interval"),
    Attribute("n_realisations, n_failed, n_undecided", "realisations, how many failed, how many have no verdict"),
    Attribute("method, seed, compute, factor", "as in [probabilistic]"),
    Attribute("fos_mean, fos_std, reliability_index_normal, reliability_index_lognormal",
              "fos mode: the FOS statistics and the reliability index (beta = (mu - 1) / sigma; lognormal: "
              "ln(mu / sqrt(1 + V^2)) / sqrt(ln(1 + V^2)))"),
    Attribute("n_fos_searches, n_srf_runs", "form, point_estimate: the points searched and the SRF runs made; "
              "pf, pf_low, pf_high and pf_running are NaN there (the points are no sample)"),
    Attribute("reliability_index_form, pf_form, reliability_index_fosm, form_iterations, form_converged, "
              "form_stop_reason", "form: beta (Hasofer-Lind, by HL-RF on FOS - factor), Phi(-beta), the first "
              "iteration's beta at the mean (FOSM), the iterations, 1 if beta changed by at most form_tolerance, why "
              "it stopped otherwise"),
    Attribute("reliability_index_sorm, pf_sorm, reliability_index_sorm_hr, pf_sorm_hr, sorm_status, sorm_searches, "
              "sorm_step, sorm_curvatures, sorm_curvature_noise, sorm_gradient_angle_deg",
              "form with sorm: beta and pf by Breitung's SORM and by Hohenbichler-Rackwitz's (each absent where it has no "
              "estimate: some 1 + beta kappa <= 0, resp. with psi; Breitung's absent, sorm_status says why and "
              "reliability_index_form stands; with one variable FORM's), the FOS searches of SORM's round and its step, the principal curvatures (per standard "
              "deviation, in one text) and the bound of their error from the searches' brackets, the angle between "
              "the gradient at the design point and its normal (0 at a true design point); absent without sorm"),
    Attribute("pf_cov, p0, samples_per_level, subset_levels, subset_accepted_share, subset_threshold_verdicts, "
              "subset_level0_searched, subset_level0_verdicts, subset_guard_verdicts, subset_guard_copies, subset_stop_reason",
              "subset_simulation: pf (in pf; pf_low and pf_high an approximate 95% interval from pf_cov, lognormal about "
              "pf) and its coefficient of variation (Au & Beck, with the chains' correlation), the levels, the share "
              "of the chains' candidates accepted, how many candidates were rejected by their one run at their "
              "level's threshold (stable there: status above_srf_max, n_runs 1), level 0's points searched in full (those "
              "of lowest predicted FOS) and those stable at the top the others ran first (n_runs 1), the candidates accepted "
              "after two runs (stable at their guard: status no_knee, fos_low the guard) and those searched again as "
              "new points (fewer than N p0 + 1 of their level below its guard), why it stopped "
              "early if it did; fos_mean, fos_std and the reliability indices are those of level 0 where it searched "
              "every point, NaN otherwise (its FOS known only below that top)"),
    Attribute("pf_discretisation_excess, pf_at_zero_spacing, form_discretisation_excess, "
              "reliability_index_form_at_zero_spacing",
              "subset_simulation and form: the expected excess of every FOS at the study's spacing over its value at "
              "h -> 0 (low and high, workflows/fos/discretisation.py) and pf (from the levels' samples) or beta (on the last "
              "linearisation) with every FOS lowered by it, each pair in one text; absent where not estimated"),
    Attribute("point_estimate_fos_mean, point_estimate_fos_std", "point_estimate: the FOS's mean and std by "
              "Rosenblueth's weights; reliability_index_normal and _lognormal from them, against factor"),
    Attribute("n_mechanisms, mechanism_edges, box_decides_fraction",
              "failed realisations whose mechanism was extracted (their run files keep particles); the fraction of "
              "them whose mechanism reaches each support it reaches (workflows/fos/domain_edges.py); the largest such "
              "fraction at a side, a welded support or a smooth base, where the box and not the soil decides"),
)

PROBABILISTIC_SWEEP_FILE = _table(
    Variable("case_folder", SWEEP_DIMS, "1", "the folder under OUT/cases/ with the case's probabilistic.nc"),
    Variable("pf", SWEEP_DIMS, "1", "probability of failure of the case: failed / decided realisations"),
    Variable("pf_low", SWEEP_DIMS, "1", "lower end of its exact (Clopper-Pearson) 95% interval"),
    Variable("pf_high", SWEEP_DIMS, "1", "upper end of its exact (Clopper-Pearson) 95% interval"),
    Variable("n_failed", SWEEP_DIMS, "1", "realisations that failed"),
    Variable("n_decided", SWEEP_DIMS, "1", "realisations with a verdict"),
    Variable("fos_mean", SWEEP_DIMS, "1", "mean FOS of the realisations (fos mode; NaN otherwise)"),
    Variable("fos_std", SWEEP_DIMS, "1", "standard deviation of the FOS of the realisations (fos mode)"),
)
"""``study.nc`` of a sweep of a probabilistic study (``[sweep]`` with ``[probabilistic]``)."""

STAGE_SWEEP_FILE = _table(
    Variable("case_folder", SWEEP_DIMS, "1", "the folder under OUT/cases/ with the case's files"),
    Variable("status", SWEEP_DIMS, "1", "done (every stage ran or was up to date) or diverged"),
    Variable("status_reason", SWEEP_DIMS, "1", "the divergence of a diverged case (empty otherwise)"),
    Variable("n_particles", SWEEP_DIMS, "1", "particles of the case (0: diverged)"),
)
"""``study.nc`` of a sweep of a stage study (no strength reduction); with each scalar of
``RUNOUT_METRICS`` over (<sweep dims>, runout_stage) and, with ``[metrics]``, each scalar of
``COLLAPSE_METRICS`` over <sweep dims>."""

SWEEP_AXIS_ATTRIBUTES = (
    Attribute("units, long_name", "of the swept field, as in the study-file reference"),
    Attribute("sweep_path", "the field's path in the study file, e.g. materials.soil.cohesion_pa"),
)

SWEEP_FILE_ATTRIBUTES = (
    Attribute("study, spfem_fos_version, created_utc, study_name", "as in a stage file (the sweep's study text)"),
    Attribute("sweep_combination", "grid or zip"),
    Attribute("sweep_axes", "the swept paths, comma separated, in the order of the dimensions"),
    Attribute("n_cases, n_cases_distinct", "cases of the sweep, and how many of them differ "
              "(identical cases share one computation)"),
)

GRADED_CLOUD_VARIABLES = ("particle_spacing",)
"""Variables of STAGE_FILE that a stage file holds only for a graded cloud (``[[geometry.refined]]``)."""

REFINEMENT_FILE = _table(
    Variable("spacing", ("level",), "m", "particle spacing h of the level (adaptive: of its finest zone, the band)"),
    Variable("n_particles", ("level",), "1", "particles of the level's slope"),
    Variable("fos", ("level",), "1", "factor of safety at the level's spacing (NaN: none, see level_verdict)"),
    Variable("fos_low", ("level",), "1", "lower end of the level's FOS bracket"),
    Variable("fos_high", ("level",), "1", "upper end of the level's FOS bracket"),
    Variable("n_runs", ("level",), "1", "SRF runs the level's FOS rests on (made now or reused)"),
    Variable("wall_time", ("level",), "s", "worker time of the level's gravity and runs made by this invocation"),
    Variable("criteria_agree", ("level",), "1", "1 when the level's run verdicts bracket the same FOS"),
    Variable("level_verdict", ("level",), "1", "the level's FOS line (its summary.nc)"),
    Variable("level_folder", ("level",), "1", "the folder under OUT/levels/ with the level's files"),
    Variable("fos_fit", ("level",), "1", "the fit of the band's procedure at the level's spacing (NaN: no band)"),
    Variable("fos_limit", (), "1",
             "factor of safety at h -> 0: f0 of the least-squares fit of the levels (Eca & Hoekstra 2014; NaN: "
             "fewer than four levels have an FOS)"),
    Variable("fos_uncertainty", (), "1", "U: the FOS lies in fos_limit -+ U with 95% confidence"),
)
"""``refinement.nc`` of a refinement study (``[refinement]``): the FOS over the ``level``
dimension (coarsest first), its value at h -> 0 and its uncertainty (docs/method.md, section 9)."""

REFINEMENT_FILE_ATTRIBUTES = (
    Attribute("study, spfem_fos_version, created_utc, study_name", "as in a stage file (the refinement's study text)"),
    Attribute("mode", "adaptive or uniform"),
    Attribute("band_low, band_high", "the discretisation band fos_limit -+ fos_uncertainty"),
    Attribute("band_trusted", "1 when the band is trusted: an observed order in range and levels that differ by "
              "more than their scatter (safety factor 1.25), else 0 (safety factor 3)"),
    Attribute("fit_kind, observed_order", "the fit the band rests on (free order, first order, second order, first "
              "and second order) and its order"),
    Attribute("error_estimate, scatter, data_range, safety_factor",
              "eps = |f_1 - f0|, the scatter s (the largest of the fit's standard deviation, the measured scatter and "
              "the levels' search resolution), Delta, Fs"),
    Attribute("measured_scatter, repeat_fos", "the scatter measured by repeating level 1 with another jitter seed, "
              "and that repeat's FOS (NaN: not repeated)"),
    Attribute("level_fos_tolerance", "each level's search tolerance"),
    Attribute("band_reason, stop_reason, verdict", "one line each: how the band was found and whether to trust it; "
              "why the levels stopped; the report's first line"),
)

SEEPAGE_FILE = _table(
    Variable("particle_x", ("particle",), "m", "x of the particle (its initial position: the flow is solved there)"),
    Variable("particle_y", ("particle",), "m", "y of the particle"),
    Variable("total_head", ("particle",), "m", "total head h: elevation plus pressure head"),
    Variable("pressure_head", ("particle",), "m", "pressure head h - y (negative above the water table)"),
    Variable("pore_pressure", ("particle",), "Pa",
             "pore pressure gamma_w max(h - y, 0) the particle carries through every stage (no suction)"),
    Variable("particle_inflow", ("particle",), "m2 s-1",
             "water entering the ground at the particle, per metre of thickness (negative: leaving; 0 inside)"),
    Variable("particle_condition", ("particle",), "1",
             "the boundary condition holding at the particle (index into condition; -1: none, no flow)"),
    Variable("mesh2d", (), "1", "the particles' first triangle mesh, on which the flow is solved (UGRID)"),
    Variable("mesh2d_face_nodes", ("face", "three"), "1", "the three particles of each triangle, counter-clockwise"),
    Variable("darcy_vx", ("face",), "m s-1", "x Darcy velocity (specific discharge) -k_r K grad h in the triangle"),
    Variable("darcy_vy", ("face",), "m s-1", "y Darcy velocity (specific discharge) in the triangle"),
    Variable("relative_permeability", ("face",), "1",
             "k_r of the triangle: 1 saturated, residual_permeability dry, between where the water table crosses it"),
    Variable("condition", ("condition",), "1",
             "name of each boundary condition: pond (ponded water) first, then the [[seepage.boundary]] names"),
    Variable("condition_inflow", ("condition",), "m2 s-1",
             "water entering the ground through each condition, per metre of thickness (negative: leaving)"),
    Variable("phreatic_x", ("segment", "end"), "m", "x of the ends of each segment of the phreatic surface (h = y)"),
    Variable("phreatic_y", ("segment", "end"), "m", "y of the ends of each segment of the phreatic surface"),
    Variable("head_change", ("iteration",), "m", "largest change of the head in each iteration"),
)
"""``seepage.nc`` of a study with ``[seepage]``: the steady flow on the particles' first mesh."""

SEEPAGE_FILE_ATTRIBUTES = (
    Attribute("study, spfem_fos_version, created_utc, study_name", "as in a stage file (the study's text)"),
    Attribute("iterations, converged, tolerance", "iterations of the free surface and seepage faces, whether the "
              "largest head change fell below tolerance times the range of the fixed heads"),
    Attribute("residual_permeability, unsaturated_band_m", "as in [seepage]"),
    Attribute("inflow_m2_s, outflow_m2_s", "the water entering and leaving the ground, per metre of thickness "
              "(their difference is the solution's mass balance)"),
    Attribute("exit_x_m, exit_y_m", "the exit point: the highest seepage-face particle water leaves through "
              "(NaN without one)"),
    Attribute("runoff_m2_s", "the rain of infiltration conditions the ground does not take (it runs off where the "
              "ground is saturated to its surface), per metre of thickness"),
    Attribute("wall_time_s", "time to build and solve the flow"),
)

TRANSIENT_FILE = _table(
    Variable("time", ("time",), "h", "the saved time (0: the initial state)"),
    Variable("particle_x", ("particle",), "m", "x of the particle (its initial position: the flow is solved there)"),
    Variable("particle_y", ("particle",), "m", "y of the particle"),
    Variable("mesh2d", (), "1", "the particles' first triangle mesh, on which the flow is solved (UGRID)"),
    Variable("mesh2d_face_nodes", ("face", "three"), "1", "the three particles of each triangle, counter-clockwise"),
    Variable("total_head", ("time", "particle"), "m", "total head h: elevation plus pressure head"),
    Variable("pressure_head", ("time", "particle"), "m", "pressure head psi = h - y (negative: suction)"),
    Variable("water_content", ("time", "particle"), "1",
             "volumetric water content theta (the lumped mean where materials meet)"),
    Variable("effective_saturation", ("time", "particle"), "1", "effective saturation S_e"),
    Variable("pore_pressure", ("time", "particle"), "Pa",
             "the pore pressure a particle carries at that time: S_e gamma_w psi (negative above the water table: "
             "suction) with suction_in_strength, else gamma_w max(psi, 0)"),
    Variable("held", ("time", "particle"), "1",
             "1 where a condition holds the particle's pressure head: at atmospheric pressure (ponding rain, a seepage "
             "face, a reservoir's face above its level) or at surface_min_head_m (a surface too dry to supply the "
             "evaporation)"),
    Variable("darcy_vx", ("time", "face"), "m s-1", "x Darcy velocity -k_r K grad h in the triangle"),
    Variable("darcy_vy", ("time", "face"), "m s-1", "y Darcy velocity in the triangle"),
    Variable("condition", ("condition",), "1", "name of each [[transient.boundary]] condition that holds particles"),
    Variable("condition_inflow", ("time", "condition"), "m2 s-1",
             "water entering the ground through each condition over the step before the time, per metre "
             "(negative: leaving)"),
    Variable("condition_cumulative_inflow", ("time", "condition"), "m2",
             "water that entered through each condition since t = 0, per metre (negative: left)"),
    Variable("water_in", ("time",), "m2", "all the water that entered the ground since t = 0, per metre"),
    Variable("water_out", ("time",), "m2", "all the water that left the ground since t = 0, per metre"),
    Variable("stored_water", ("time",), "m2", "the water the ground holds (with the saturated storage), per metre"),
    Variable("balance_error", ("time",), "m2", "water in less water out less the change of the stored water"),
    Variable("balance_fraction", ("time",), "1",
             "|balance_error| over the largest of water_in, water_out and the change of the stored water"),
    Variable("rain_intensity", ("time",), "mm h-1", "the intensity of the first rain condition at that time, less "
             "its evaporation_mm_h (negative: evaporation; the demand, the soil may give less)"),
    Variable("reservoir_level", ("time",), "m", "the reservoir's level at that time (NaN: no reservoir)"),
    Variable("step_end_time", ("step",), "s", "the end of each accepted time step of the flow"),
    Variable("step_length", ("step",), "s", "the length of each accepted step"),
    Variable("step_iterations", ("step",), "1", "modified Picard iterations of each accepted step"),
)
"""``transient.nc`` of a study with ``[transient]`` (the FOS against time): the flow at each saved time."""

TRANSIENT_FILE_ATTRIBUTES = (
    Attribute("study, spfem_fos_version, created_utc, study_name", "as in a stage file (the study's text)"),
    Attribute("largest_balance_fraction", "the worst balance_fraction of the saved times (the mass balance's "
              "closure)"),
    Attribute("largest_step_balance_fraction", "the worst closure of one step (its error over the magnitude of its "
              "balance)"),
    Attribute("steps, rejected_steps, solves, factorizations", "accepted and rejected time steps, linear solves and "
              "LU factorizations of the flow"),
    Attribute("wall_time_s", "time to build and solve the flow"),
)

FOS_TIME_FILE = _table(
    Variable("time", ("time",), "h", "the time of the water each FOS is searched with"),
    Variable("fos", ("time",), "1", "the factor of safety at that time (the case's summary.nc)"),
    Variable("fos_low", ("time",), "1", "the lower end of its bracket"),
    Variable("fos_high", ("time",), "1", "the upper end of its bracket"),
    Variable("runs", ("time",), "1", "the strength-reduction runs its search made"),
    Variable("window_low", ("time",), "1", "the lower end of the window its search started in (NaN: none, the "
             "first time)"),
    Variable("window_high", ("time",), "1", "the upper end of that window"),
    Variable("rain_intensity", ("time",), "mm h-1", "the intensity of the first rain condition at that time, less "
             "its evaporation_mm_h (negative: evaporation; the demand, the soil may give less)"),
    Variable("cumulative_rain", ("time",), "mm", "the rain of the first rain condition fallen since t = 0, less its "
             "evaporation_mm_h"),
    Variable("reservoir_level", ("time",), "m", "the reservoir's level at that time (NaN: no reservoir)"),
    Variable("water_in", ("time",), "m2", "all the water that entered the ground since t = 0, per metre"),
)
"""``fos_time.nc`` of a study of the FOS against time."""

FOS_TIME_FILE_ATTRIBUTES = (
    Attribute("study, spfem_fos_version, created_utc, study_name", "as in a stage file (the study's text)"),
    Attribute("time_fos_one_h", "when the FOS reaches 1, linear between the times either side (NaN: it does not)"),
    Attribute("stop_below_fos, stopped_at_h", "the study's stop rule and the time it stopped at (NaN: it ran every "
              "time)"),
)

THRESHOLD_FILE = _table(
    Variable("duration_to_fos_1", ("<other axis>",), "h",
             "the water_at_h at which the FOS falls to 1 for each value of the sweep's other axis (a rain intensity: "
             "the slope's intensity-duration threshold), linear between the swept times either side; the first "
             "time if it is below 1 there, NaN if it stays above 1 at every swept time"),
    Variable("lowest_fos", ("<other axis>",), "1", "the lowest FOS along the swept times"),
)
"""``threshold.nc`` of a sweep of a ``[transient]`` study over ``transient.water_at_h`` and one other axis."""
