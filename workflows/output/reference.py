"""The result-file reference page, generated from the declarations in :mod:`workflows.output.variables`.

    python -m workflows.output.reference > docs/result-files.md

The test suite fails when ``docs/result-files.md`` differs from :func:`page`.
"""

from __future__ import annotations

import sys

from workflows.output.variables import (
    COLLAPSE_METRICS,
    FOS_ATTRIBUTES,
    FOS_TIME_FILE,
    FOS_TIME_FILE_ATTRIBUTES,
    PROBABILISTIC_FILE,
    PROBABILISTIC_FILE_ATTRIBUTES,
    PROBABILISTIC_SWEEP_FILE,
    REFINED_SWEEP_FILE,
    REFINEMENT_FILE,
    REFINEMENT_FILE_ATTRIBUTES,
    RUNOUT_METRICS,
    SEEPAGE_FILE,
    SEEPAGE_FILE_ATTRIBUTES,
    STAGE_FILE,
    STAGE_FILE_ATTRIBUTES,
    STAGE_SWEEP_FILE,
    SUMMARY_FILE,
    SUMMARY_FILE_ATTRIBUTES,
    SWEEP_AXIS_ATTRIBUTES,
    SWEEP_FILE,
    SWEEP_FILE_ATTRIBUTES,
    THRESHOLD_FILE,
    TRANSIENT_FILE,
    TRANSIENT_FILE_ATTRIBUTES,
    Attribute,
    Variable,
)

REGENERATE = "python -m workflows.output.reference > docs/result-files.md"

INTRO = """\
# Result-file reference

Every result is a netCDF-4 file that follows the CF conventions (UGRID for the particle mesh):
every variable has `units` (UDUNITS; `1` for a number or a label) and `long_name`, and every file
carries the study text that made it.  Files are written to `<name>.tmp` and renamed, so a file
with its final name is complete.  Open them with xarray (`xr.open_dataset(path)`), ParaView
(`python -m workflows.output.paraview OUT` writes `.vtu` files and a `.pvd` collection) or the
notebooks in `studies/notebooks/`.

| file | written by |
|---|---|
| `OUT/run.nc` | a study with one stage |
| `OUT/<stage>.nc` | each stage of a study with several stages; `gravity.nc` of an FOS study |
| `OUT/srf_<F>.nc` | each strength-reduction run of an FOS study (a stage file of the last stage) |
| `OUT/summary.nc` | an FOS study: one row per SRF run and the factor of safety |
| `OUT/srf_curve.png`, `OUT/fields_srf_<F>.png` | an FOS study with `[output] figures = true` |
| `OUT/study.nc` | a sweep: the FOS of every case over the sweep's dimensions |
| `OUT/cases/<case>/` | a sweep: each case's files, as an FOS study's (`case.toml` its study text; no figures) |
| `OUT/fos_<axis>.png`, `OUT/fos_map.png` | a sweep with `[output] figures = true`: FOS against each axis, and the map of a grid of two or more axes |
| `OUT/seepage.nc`, `OUT/seepage.png` | a study with `[seepage]`: the steady flow whose pore pressures every stage uses (beside `gravity.nc` in an FOS study) |
"""


def _variables(table: dict[str, Variable]) -> list[str]:
    lines = ["| variable | dims | units | long name |", "|---|---|---|---|"]
    for v in table.values():
        dims = ", ".join(v.dims) if v.dims else "(scalar)"
        lines.append(f"| `{v.name}` | {dims} | {v.units} | {v.long_name} |")
    return lines


def _attributes(attributes: tuple[Attribute, ...]) -> list[str]:
    lines = ["| attribute | content |", "|---|---|"]
    lines += [f"| `{a.name}` | {a.meaning} |" for a in attributes]
    return lines


def page() -> str:
    """The whole reference page (``docs/result-files.md``)."""
    note = f"<!-- generated from workflows/output/variables.py by `{REGENERATE}`; do not edit -->"
    parts = [note, INTRO]
    parts += ["## Stage files (`run.nc`, `<stage>.nc`, `gravity.nc`, `srf_<F>.nc`)", "", *_variables(STAGE_FILE), "",
              "Global attributes:", "", *_attributes(STAGE_FILE_ATTRIBUTES), ""]
    parts += ["## Collapse metrics", "",
              "With `[metrics]`, the last stage's file also holds these scalars (granular or cohesive, by "
              "`metrics.kind`; attribute `metrics_kind`), computed on the final state of the particles inside "
              "the mesh (`workflows/collapse/metrics.py` defines each):", "", *_variables(COLLAPSE_METRICS), ""]
    parts += ["## Runout metrics", "",
              "The file of a `runout` stage also holds these (attribute `metrics_kind` = `runout`; "
              "`workflows/runout/metrics.py` defines each, x measured down the slope).  Attribute `final` is 1 when "
              "they are final, 0 when the flow (a sliding mass) was still moving at `max_duration_s` or its deposit reached the end "
              "of the domain; attribute `warning` then says which (the command prints it too):", "",
              *_variables(RUNOUT_METRICS), ""]
    parts += ["## `summary.nc` of a strength-reduction study", "", *_variables(SUMMARY_FILE), "",
              "Attributes of `fos`:", "", *_attributes(FOS_ATTRIBUTES), "",
              "Global attributes:", "", *_attributes(SUMMARY_FILE_ATTRIBUTES), ""]
    parts += ["## `study.nc` of a sweep", "",
              "Dimensions `<sweep dims>`: one per axis of a grid, named by the axis label (the field's name, e.g. "
              "`cohesion_pa`; with the entry or table before it, `soil_cohesion_pa`, where two axes share a name), "
              "with the axis values as coordinate; a zip has the one dimension `case`, each axis a coordinate "
              "over it.", "", *_variables(SWEEP_FILE), "",
              "Attributes of each axis coordinate:", "", *_attributes(SWEEP_AXIS_ATTRIBUTES), "",
              "Global attributes:", "", *_attributes(SWEEP_FILE_ATTRIBUTES), ""]
    parts += ["## `study.nc` of a sweep of a stage study", "",
              "A sweep of a study with no strength_reduction stage (a runout, a collapse) runs each case's stages "
              "(`workflows/sweep/study_type.py`); its `study.nc` has the same dimensions and axis coordinates, "
              "the attributes above but `n_cases_distinct`, and:", "", *_variables(STAGE_SWEEP_FILE), "",
              "With runout stages, the dimension `runout_stage` (coordinate: the stage names) and every scalar of "
              "the [runout metrics](#runout-metrics) over (`<sweep dims>`, `runout_stage`); with `[metrics]`, every "
              "scalar of the [collapse metrics](#collapse-metrics) of the last stage over `<sweep dims>`.", ""]
    parts += ["## `refinement.nc` of a refinement study", "",
              "A study with `[refinement]` (`workflows/refinement/`): each level's FOS over the dimension `level` "
              "(coarsest first; each level's own files under `OUT/levels/<level>_h=<h>/`, as a single study's) and "
              "the FOS at h -> 0 with its discretisation band (docs/method.md, section 9).", "",
              *_variables(REFINEMENT_FILE), "", "Global attributes:", "", *_attributes(REFINEMENT_FILE_ATTRIBUTES), ""]
    parts += ["## `study.nc` of a sweep with `[refinement]`", "",
              "Every case is a refinement study in `OUT/cases/<case>/` (its `refinement.nc` as above; "
              "`workflows/refinement/sweep.py`). `study.nc` has the variables and attributes of a sweep's, "
              "those of each case's finest level, and:", "", *_variables(REFINED_SWEEP_FILE), ""]
    parts += ["## `probabilistic.nc` of a probabilistic study", "",
              "A study with `[probabilistic]` (`workflows/probabilistic/`): every realisation over the dimension "
              "`realisation` (each one's files under `OUT/cases/realisation_<i>/`, as a sweep's case), and the "
              "study's statistics as attributes.", "", *_variables(PROBABILISTIC_FILE), "",
              "Global attributes:", "", *_attributes(PROBABILISTIC_FILE_ATTRIBUTES), ""]
    parts += ["## `study.nc` of a sweep of a probabilistic study", "",
              "A study with `[sweep]` and `[probabilistic]` (`workflows/probabilistic/sweep.py`): every case is a "
              "probabilistic study in `OUT/cases/<case>/` (its `probabilistic.nc` as above, its realisations "
              "under `OUT/cases/<case>/cases/`). `study.nc` has the dimensions, axis coordinates and attributes "
              "of a sweep's, and:", "", *_variables(PROBABILISTIC_SWEEP_FILE), ""]
    parts += ["## `seepage.nc` of a study with `[seepage]`", "",
              "The steady flow (`workflows/seepage/`, docs/method.md section 15) on the particles' first mesh: "
              "heads and pore pressure at the particles, Darcy velocities in the triangles, the water through "
              "each boundary condition and the phreatic surface.", "", *_variables(SEEPAGE_FILE), "",
              "Global attributes:", "", *_attributes(SEEPAGE_FILE_ATTRIBUTES), ""]
    parts += ["## `transient.nc` and `fos_time.nc` of the FOS against time", "",
              "A study with `[transient]` and `fos_times_h` or `fos_interval_h` (`workflows/transient/`, docs/method.md "
              "section 17): the transient flow on the particles' first mesh at each saved time, with its water "
              "balance, in `transient.nc`:", "", *_variables(TRANSIENT_FILE), "",
              "Global attributes:", "", *_attributes(TRANSIENT_FILE_ATTRIBUTES), "",
              "and the FOS at each time (each time's own files under `OUT/times/t=<t>h/`, as a single study's) in "
              "`fos_time.nc`:", "", *_variables(FOS_TIME_FILE), "",
              "Global attributes:", "", *_attributes(FOS_TIME_FILE_ATTRIBUTES), ""]
    parts += ["## `threshold.nc` of a sweep over the time of the water", "",
              "A grid `[sweep]` of a `[transient]` study over `transient.water_at_h` and one other axis (a rain "
              "intensity: the slope's intensity-duration threshold; `workflows/fos_time/threshold.py`), beside its "
              "`study.nc`, over the other axis:", "", *_variables(THRESHOLD_FILE), "",
              "Global attributes: `time_axis`, `other_axis` (the two axis labels) and those of every result file.", ""]
    return "\n".join(parts)


if __name__ == "__main__":
    sys.stdout.write(page())
