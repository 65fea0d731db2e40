"""Result files: one netCDF file per stage run, self-describing and written atomically.

A study with a single stage writes ``OUT/run.nc``; a study with several stages writes
``OUT/<stage name>.nc`` for each.  Each file holds

- the monitor histories (dims ``monitor``, ``time``) with ``monitor`` the names of the study,
- the kinetic energy and the largest displacement (dim ``time``),
- the particles at the end of the stage (dim ``particle``) and their triangle mesh with
  UGRID names (``mesh2d``, ``mesh2d_face_nodes``),
- the study text, the code version and the run's counters as global attributes.

Every variable has ``units`` (UDUNITS spelling) and ``long_name``.  A file is written to
``<name>.tmp`` and renamed, so a file with the final name is always complete.
"""

from __future__ import annotations

import os
import re
import signal
import threading
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path

import netCDF4
import numpy as np
import xarray as xr

from workflows import __version__
from workflows.study import Study, specs

SINGLE_RUN_NAME = "run.nc"

_MONITOR_COMPONENTS = {
    # variable: (TimeSeries field, component, units, long_name)
    "monitor_ux": ("monitor_displacement_m", 0, "m", "x displacement of the monitored particle"),
    "monitor_uy": ("monitor_displacement_m", 1, "m", "y displacement of the monitored particle"),
    "monitor_vx": ("monitor_velocity_m_s", 0, "m s-1", "x velocity of the monitored particle"),
    "monitor_vy": ("monitor_velocity_m_s", 1, "m s-1", "y velocity of the monitored particle"),
    "monitor_sxx": ("monitor_stress_pa", 0, "Pa", "stress xx at the monitored particle (tension positive)"),
    "monitor_syy": ("monitor_stress_pa", 1, "Pa", "stress yy at the monitored particle (tension positive)"),
    "monitor_szz": ("monitor_stress_pa", 2, "Pa", "out-of-plane stress zz at the monitored particle"),
    "monitor_sxy": ("monitor_stress_pa", 3, "Pa", "shear stress xy at the monitored particle"),
}

_PARTICLE_COMPONENTS = {
    # variable: (final-state attribute of the simulation, component, units, long_name)
    "particle_x": ("node_xy_m", 0, "m", "x of the particle at the end of the stage"),
    "particle_y": ("node_xy_m", 1, "m", "y of the particle at the end of the stage"),
    "particle_ux": ("node_displacement_m", 0, "m", "x displacement of the particle"),
    "particle_uy": ("node_displacement_m", 1, "m", "y displacement of the particle"),
    "particle_vx": ("node_velocity_m_s", 0, "m s-1", "x velocity of the particle"),
    "particle_vy": ("node_velocity_m_s", 1, "m s-1", "y velocity of the particle"),
    "particle_sxx": ("node_stress_pa", 0, "Pa", "stress xx at the particle (tension positive)"),
    "particle_syy": ("node_stress_pa", 1, "Pa", "stress yy at the particle (tension positive)"),
    "particle_szz": ("node_stress_pa", 2, "Pa", "out-of-plane stress zz at the particle"),
    "particle_sxy": ("node_stress_pa", 3, "Pa", "shear stress xy at the particle"),
}

_ENERGY_LONG_NAMES = {
    "strain": "elastic strain energy per metre of thickness",
    "gravity_potential": "gravitational potential energy per metre of thickness, relative to the stage start",
    "damping_dissipated": "energy removed by local damping since the stage start, per metre of thickness",
    "stabilisation_dissipated": "energy removed by the stabilisation since the stage start, per metre of thickness",
    "plastic_dissipated": "energy dissipated by plastic flow since the stage start, per metre of thickness",
    "contact_dissipated": "kinetic energy removed by the rigid walls since the stage start, per metre of thickness",
}


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


def run_dataset(*, study: Study, stage_index: int, series, sim, scene, monitor_particles) -> xr.Dataset:
    """The result of one stage as a dataset (nothing is written).

    ``series`` is the stage's ``TimeSeries``; ``sim`` gives the final state
    (``node_xy_m``, ``node_displacement_m``, ``node_velocity_m_s``, ``node_stress_pa``,
    ``mesh.elem_nodes``) and ``dt_s``, ``critical_dt_s``; ``scene`` gives the initial
    positions and material of each particle; ``monitor_particles`` the particle index of
    each ``[[monitors]]`` entry.
    """
    monitor_particles = np.asarray(monitor_particles, dtype=np.int64)
    ds = xr.Dataset(
        coords={
            "time": (
                "time",
                np.asarray(series.time_s, dtype=np.float64),
                {"units": "s", "long_name": "time since the start of the stage"},
            ),
            "monitor": (
                "monitor",
                np.array([m.name for m in study.monitors], dtype=str),
                {"units": "1", "long_name": "monitor name, as given in the study"},
            ),
        }
    )
    ds["monitor_particle"] = (
        "monitor",
        monitor_particles,
        {"units": "1", "long_name": "index of the particle nearest to the monitor point, followed by the monitor"},
    )
    for axis, column in (("x", 0), ("y", 1)):
        ds[f"monitor_{axis}0"] = (
            "monitor",
            scene.node_xy_m[monitor_particles, column],
            {"units": "m", "long_name": f"initial {axis} of the monitored particle"},
        )
    for variable, (field, component, units, long_name) in _MONITOR_COMPONENTS.items():
        history = np.asarray(getattr(series, field), dtype=np.float64)[:, :, component]
        ds[variable] = (("monitor", "time"), history.T, {"units": units, "long_name": long_name})
    ds["kinetic_energy"] = (
        "time",
        np.asarray(series.kinetic_energy_j_per_m, dtype=np.float64),
        {"units": "J m-1", "long_name": "total kinetic energy per metre of out-of-plane thickness"},
    )
    energy = np.asarray(series.energy_j_per_m, dtype=np.float64)
    for column, name in enumerate(series.energy_columns):
        if name != "kinetic":  # written above under its own name
            long_name = _ENERGY_LONG_NAMES.get(name, f"energy: {name}")
            ds[f"energy_{name}"] = ("time", energy[:, column], {"units": "J m-1", "long_name": long_name})
    ds["max_displacement"] = (
        "time",
        np.asarray(series.max_displacement_m, dtype=np.float64),
        {"units": "m", "long_name": "largest displacement magnitude of any particle"},
    )

    for variable, (attribute, component, units, long_name) in _PARTICLE_COMPONENTS.items():
        values = np.asarray(getattr(sim, attribute), dtype=np.float64)[:, component]
        ds[variable] = ("particle", values, {"units": units, "long_name": long_name})
    ds["particle_x0"] = ("particle", np.asarray(sim.node_initial_xy_m[:, 0]), {"units": "m", "long_name": "initial x of the particle"})
    ds["particle_y0"] = ("particle", np.asarray(sim.node_initial_xy_m[:, 1]), {"units": "m", "long_name": "initial y of the particle"})
    ds["particle_plastic_strain"] = (
        "particle",
        np.asarray(sim.node_plastic_strain, dtype=np.float64),
        {"units": "1", "long_name": "equivalent plastic strain, sum of sqrt(2/3 de_p:de_p) since the start"},
    )
    ds["particle_area"] = (
        "particle",
        np.asarray(sim.node_area_m2, dtype=np.float64),
        {"units": "m2", "long_name": "smoothing-cell area of the particle on the final mesh"},
    )
    ds["particle_mass"] = (
        "particle",
        np.asarray(sim.node_mass_kg, dtype=np.float64),
        {"units": "kg m-1", "long_name": "particle mass per metre of thickness (fixed at the start)"},
    )
    material_names = scene.materials.name
    ds["particle_material"] = (
        "particle",
        np.asarray(scene.node_material, dtype=np.int64),
        {
            "units": "1",
            "long_name": "material of the particle (row of [[materials]])",
            "flag_values": np.arange(len(material_names), dtype=np.int64),
            "flag_meanings": " ".join(material_names),
        },
    )
    ds["mesh2d"] = (
        (),
        np.int32(0),
        {
            "units": "1",
            "long_name": "triangle mesh of the particles at the end of the stage",
            "cf_role": "mesh_topology",
            "topology_dimension": 2,
            "node_coordinates": "particle_x particle_y",
            "node_dimension": "particle",
            "face_node_connectivity": "mesh2d_face_nodes",
            "face_dimension": "face",
        },
    )
    ds["mesh2d_face_nodes"] = (
        ("face", "three"),
        np.asarray(sim.mesh.elem_nodes, dtype=np.int64),
        {
            "units": "1",
            "long_name": "particles at the corners of each triangle, counter-clockwise",
            "cf_role": "face_node_connectivity",
            "start_index": 0,
        },
    )
    for variable in ("particle_x", "particle_y"):
        ds[variable].attrs["mesh"] = "mesh2d"
        ds[variable].attrs["location"] = "node"
    ds.attrs = global_attributes(study, stage_index, series, sim)
    return ds


def particle_stress(ds: xr.Dataset) -> np.ndarray:
    """The final particle stresses of a result dataset as (n, 4) xx, yy, zz, xy in Pa."""
    return np.stack([ds[f"particle_s{c}"].values for c in ("xx", "yy", "zz", "xy")], axis=1)


def global_attributes(study: Study, stage_index: int, series, sim) -> dict:
    """Provenance and counters of one stage run."""
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
        n_particles=int(sim.n_particles),
        n_steps=int(series.n_steps),
        n_remesh=int(series.n_remesh),
        wall_time_s=float(series.wall_time_s),
        dt_s=float(sim.dt_s),
        critical_dt_s=float(sim.critical_dt_s),
    )
    if series.converged is not None:
        attrs["converged"] = int(bool(series.converged))
        attrs["unbalanced_force_ratio"] = float(series.unbalanced_force_ratio)
    for key, value in (series.notes or {}).items():
        attrs["note_" + re.sub(r"\W+", "_", key).strip("_")] = str(value)
    attrs.update(
        study=study.source_text,
        spfem_fos_version=__version__,
        created_utc=datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
    )
    return attrs


@contextmanager
def interrupts_deferred():
    """Hold Ctrl-C (SIGINT) and SIGTERM back until the block ends (main thread only).

    A KeyboardInterrupt raised inside the netCDF/HDF5 writer while a file is open can leave
    its lock held and hang the clean-up.  Blocking the signal is not enough: the kernel hands
    it to another thread (dask's), and Python still raises it in the main thread.  So the
    handlers are swapped for ones that only note the signal, which is raised at the end."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    held = (signal.SIGINT, signal.SIGTERM)
    previous = {signum: signal.signal(signum, lambda signum, frame: received.append(signum)) for signum in held}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if signal.SIGINT in received:
            raise KeyboardInterrupt
        if received:
            signal.raise_signal(received[0])


_NETCDF_WRITE_LOCK = threading.Lock()
"""Our own lock around the HDF5 calls of a write (see ``write_dataset``)."""


def write_dataset(ds: xr.Dataset, path: str | Path) -> Path:
    """Write ``ds`` to ``path`` through ``<path>.tmp`` and a rename; no temp file survives an error,
    and an interrupt waits until the file is complete (or removed).

    The store is opened with an explicit lock.  ``Dataset.to_netcdf`` picks its lock from the
    global dask configuration instead: with a dask client open it takes a ``distributed.Lock``
    (a round trip to the scheduler) around every HDF5 call, which made a 40 ms run file take
    0.3-0.9 s during an FOS study; and a client starting or closing in another thread changes
    that configuration in the middle of a write.
    """
    from xarray.backends import NetCDF4DataStore

    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with interrupts_deferred():
        try:
            store = NetCDF4DataStore.open(str(tmp), mode="w", format="NETCDF4", lock=_NETCDF_WRITE_LOCK)
            try:
                ds.dump_to_store(store)
            finally:
                store.close()
            os.replace(tmp, path)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
    return path


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

