"""The result file of one stage: monitor histories, energies and the final particle state.

A study with a single stage writes ``OUT/run.nc``; a study with several stages writes
``OUT/<stage name>.nc`` for each.  Each file holds the variables of
:data:`workflows.output.variables.STAGE_FILE` (units and long names from there): the monitor
histories over ``time`` with ``monitor`` the names of the study, the energy budget and the
largest displacement, the particles at the end of the stage with their triangle mesh under
UGRID names (``mesh2d``, ``mesh2d_face_nodes``), and as global attributes the study text, the
code version and the run's counters.
"""

from __future__ import annotations

import re
from datetime import UTC, datetime
from pathlib import Path

import netCDF4
import numpy as np
import xarray as xr

from spfem_core import __version__
from spfem_core.energy_budget import ENERGY_COLUMNS
from spfem_core.snapshot import StressState
from workflows.fields import specs
from workflows.output.variables import STAGE_FILE, energy_variable_name
from workflows.study import Study

SINGLE_RUN_NAME = "run.nc"

_VECTOR_COMPONENTS = {"displacement_m": ("ux", "uy"), "velocity_m_s": ("vx", "vy"),
                      "stress_pa": ("sxx", "syy", "szz", "sxy")}
"""Field of the state (``Snapshot``; ``monitor_`` + field of the ``TimeSeries``) -> the suffix of
each component's variable."""
_MONITOR_COMPONENTS = {f"monitor_{suffix}": (f"monitor_{field}", component)
                       for field, suffixes in _VECTOR_COMPONENTS.items() for component, suffix in enumerate(suffixes)}
_PARTICLE_COMPONENTS = {f"particle_{suffix}": (field, component)
                        for field, suffixes in {"xy_m": ("x", "y"), **_VECTOR_COMPONENTS}.items()
                        for component, suffix in enumerate(suffixes)}

STRESS_VARIABLES = ("particle_sxx", "particle_syy", "particle_szz", "particle_sxy")


def result_paths(study: Study, out_dir: str | Path) -> list[Path]:
    """Where each stage of ``study`` writes its result, in stage order."""
    out_dir = Path(out_dir)
    if len(study.stages) == 1:
        return [out_dir / SINGLE_RUN_NAME]
    return [out_dir / f"{stage.name}.nc" for stage in study.stages]


def _attribute_value(value):
    """A value netCDF can store as an attribute (None is left out by the caller)."""
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, tuple) and all(isinstance(v, str) for v in value):
        return ", ".join(value)
    if isinstance(value, tuple):
        return np.array(value, dtype=np.float64).ravel()
    return value


def stage_dataset(*, study: Study, stage_index: int, series, final, monitor_particles,
                  particles: bool = True) -> xr.Dataset:
    """The result of one stage as a dataset (nothing is written).

    ``series`` is the stage's ``TimeSeries``; ``final`` the particles at its end (a
    ``spfem_core.snapshot.Snapshot``); ``monitor_particles`` the particle index of each
    ``[[monitors]]`` entry.  ``particles=False`` leaves out the final particle state and its mesh
    (the ``particle`` and ``face`` variables): the run of a realisation a probabilistic study
    does not keep (``[probabilistic] keep_fields``), whose histories and counters stay.
    The variables are gathered first and made into one Dataset at once (a Dataset grown a
    variable at a time aligns them all again at each step: 10 times slower).
    """
    var = STAGE_FILE
    monitor_particles = np.asarray(monitor_particles, dtype=np.int64)
    initial_xy = final.initial_xy_m
    data = {
        "monitor_particle": var["monitor_particle"](monitor_particles),
        "monitor_x0": var["monitor_x0"](initial_xy[monitor_particles, 0]),
        "monitor_y0": var["monitor_y0"](initial_xy[monitor_particles, 1]),
    }
    for name, (field, component) in _MONITOR_COMPONENTS.items():
        data[name] = var[name](np.asarray(getattr(series, field), dtype=np.float64)[:, :, component].T)
    energy = np.asarray(series.energy_j_per_m, dtype=np.float64)
    for column, energy_name in enumerate(ENERGY_COLUMNS):
        name = energy_variable_name(energy_name)
        data[name] = var[name](energy[:, column])
    data["max_displacement"] = var["max_displacement"](np.asarray(series.max_displacement_m, dtype=np.float64))
    data["max_speed"] = var["max_speed"](np.asarray(series.max_speed_m_s, dtype=np.float64))
    if particles:
        data.update(_particle_variables(final))
    ds = xr.Dataset(data, coords={
        "time": var["time"](np.asarray(series.time_s, dtype=np.float64)),
        "monitor": var["monitor"](np.array([m.name for m in study.monitors], dtype=str)),
    })
    ds.attrs = global_attributes(study, stage_index, series, final)
    return ds


def _particle_variables(final) -> dict:
    """The final particle state of ``final`` (a ``Snapshot``) and its UGRID mesh, as (dims, values,
    attrs) by variable name."""
    var = STAGE_FILE
    initial_xy = final.initial_xy_m
    data = {}
    for name, (field, component) in _PARTICLE_COMPONENTS.items():
        data[name] = var[name](np.asarray(getattr(final, field), dtype=np.float64)[:, component])
    for name in ("particle_x", "particle_y"):
        data[name] = var[name](data[name][1], mesh="mesh2d", location="node")
    data["particle_x0"] = var["particle_x0"](np.asarray(initial_xy[:, 0]))
    data["particle_y0"] = var["particle_y0"](np.asarray(initial_xy[:, 1]))
    data["particle_plastic_strain"] = var["particle_plastic_strain"](final.plastic_strain)
    data["particle_area"] = var["particle_area"](final.area_m2)
    if final.particle_spacing_m is not None:  # a graded cloud ([[geometry.refined]])
        data["particle_spacing"] = var["particle_spacing"](final.particle_spacing_m)
    data["particle_mass"] = var["particle_mass"](final.mass_kg)
    data["particle_pore_pressure"] = var["particle_pore_pressure"](final.pore_pressure_pa)
    material_names = final.material_names
    data["particle_material"] = var["particle_material"](
        final.material, flag_values=np.arange(len(material_names), dtype=np.int64),
        flag_meanings=" ".join(material_names),
    )
    data["mesh2d"] = var["mesh2d"](
        np.int32(0), cf_role="mesh_topology", topology_dimension=2, node_coordinates="particle_x particle_y",
        node_dimension="particle", face_node_connectivity="mesh2d_face_nodes", face_dimension="face",
    )
    data["mesh2d_face_nodes"] = var["mesh2d_face_nodes"](
        final.elem_nodes, cf_role="face_node_connectivity", start_index=0,
    )
    return data


def particle_stress(ds: xr.Dataset) -> np.ndarray:
    """The final particle stresses of a result dataset as (n, 4) xx, yy, zz, xy in Pa."""
    return np.stack([ds[name].values for name in STRESS_VARIABLES], axis=1)


def stress_state(ds: xr.Dataset) -> StressState:
    """The stress state at the end of a result dataset's stage (stress and plastic strain)."""
    return StressState(particle_stress(ds), ds["particle_plastic_strain"].values)


def global_attributes(study: Study, stage_index: int, series, final) -> dict:
    """Provenance and counters of one stage run (``variables.STAGE_FILE_ATTRIBUTES``)."""
    stage = study.stages[stage_index]
    attrs = {
        "title": f"spfem-fos study {study.name}, stage {stage.name}",
        "Conventions": "CF-1.11 UGRID-1.0",
        "study_name": study.name,
        "stage_index": stage_index,
        "n_stages": len(study.stages),
        "stage_name": stage.name,
        "stage_kind": stage.kind,
    }
    for field_name in specs(type(stage)):
        value = getattr(stage, field_name)
        if field_name == "boundary" and value is None:
            value = tuple(b.name for b in study.boundary)  # default: every boundary
        if field_name != "name" and value is not None:
            attrs[f"stage_{field_name}"] = _attribute_value(value)
    attrs.update(
        n_particles=int(final.n_particles),
        n_steps=int(series.n_steps),
        n_remesh=int(series.n_remesh),
        wall_time_s=float(series.wall_time_s),
        dt_s=float(series.dt_s),  # the step the stage took (a relaxation its own, not solver.dt_s)
        critical_dt_s=float(final.critical_dt_s),
    )
    if series.converged is not None:
        attrs["converged"] = int(bool(series.converged))
        attrs["unbalanced_force_ratio"] = float(series.unbalanced_force_ratio)
    for key, value in (series.notes or {}).items():
        attrs["note_" + re.sub(r"\W+", "_", key).strip("_")] = str(value)
    attrs.update(provenance(study))
    return attrs


def provenance(study: Study) -> dict:
    """What every result file carries about its origin: the study text, the version, the time."""
    return {
        "study": study.source_text,
        "spfem_fos_version": __version__,
        "created_utc": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
    }


def stored_study_text(path: str | Path) -> str | None:
    """The ``study`` attribute of a result file, or None if the file is missing or unreadable."""
    try:
        with netCDF4.Dataset(path) as nc:
            return nc.getncattr("study")
    except (OSError, AttributeError, RuntimeError):
        return None


def is_up_to_date(path: str | Path, study: Study) -> bool:
    """True if ``path`` is a finished result of exactly this study text."""
    return Path(path).is_file() and stored_study_text(path) == study.source_text
