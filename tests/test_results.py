"""Result files from a fake TimeSeries: variables, units, UGRID mesh, provenance, atomic write."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from spfem_core import MaterialTable, Scene
from spfem_core.energy_budget import ENERGY_COLUMNS
from spfem_core.snapshot import Snapshot
from workflows.output.stage_file import is_up_to_date, result_paths, stage_dataset
from workflows.output.writing import write_dataset
from workflows.study import parse_study

REPO = Path(__file__).resolve().parents[1]
REQUIRED_VARIABLES = [
    "time", "monitor", "monitor_ux", "monitor_uy", "monitor_vx", "monitor_vy",
    "monitor_sxx", "monitor_syy", "monitor_szz", "monitor_sxy", "kinetic_energy", "max_displacement",
    "particle_x", "particle_y", "particle_ux", "particle_uy", "particle_sxx", "particle_syy",
    "particle_szz", "particle_sxy", "mesh2d", "mesh2d_face_nodes",
]  # fmt: skip
REQUIRED_ATTRIBUTES = [
    "n_particles", "n_steps", "n_remesh", "wall_time_s", "dt_s", "study", "spfem_fos_version", "created_utc",
]  # fmt: skip


@dataclass
class FakeTimeSeries:
    """The fields of the core's TimeSeries, filled with recognisable numbers."""

    n_rec: int
    n_mon: int
    n_steps: int = 500
    n_remesh: int = 2
    wall_time_s: float = 0.25
    dt_s: float = 1e-4
    converged: bool | None = None
    unbalanced_force_ratio: float = 3e-6
    notes: dict = field(default_factory=lambda: {"stabilisation": "off (beta = 0)", "remesh": "2 rebuilds"})

    def __post_init__(self):
        shape = (self.n_rec, self.n_mon)
        self.time_s = np.linspace(0.0, 0.05, self.n_rec)
        ramp = np.arange(self.n_rec * self.n_mon, dtype=float).reshape(shape)
        self.monitor_displacement_m = np.stack([ramp, -ramp], axis=-1)
        self.monitor_velocity_m_s = np.stack([2 * ramp, -2 * ramp], axis=-1)
        self.monitor_stress_pa = np.stack([ramp + k for k in range(4)], axis=-1)
        self.energy_j_per_m = np.column_stack([np.linspace(0.0, k + 1.0, self.n_rec) for k in range(len(ENERGY_COLUMNS))])
        self.max_displacement_m = np.linspace(0.0, 0.1, self.n_rec)
        self.max_speed_m_s = np.linspace(0.0, 0.5, self.n_rec)


def fake_run(study_text: str, n_rec: int = 6, **series_options):
    """(study, scene, final particles, series, monitor particles) for a 4 x 3 lattice of particles."""
    study = parse_study(study_text)
    x, y = np.meshgrid(np.linspace(0.0, 2.0, 4), np.linspace(0.0, 0.2, 3))
    node_xy_m = np.column_stack([x.ravel(), y.ravel()])
    n = node_xy_m.shape[0]
    materials = MaterialTable(tuple(m.name for m in study.materials), [0], [1850.0], [80e6], [0.25])
    scene = Scene(node_xy_m=node_xy_m, node_material=np.zeros(n, dtype=np.int64), materials=materials, spacing_m=0.5)
    final = Snapshot(
        time_s=0.5, xy_m=node_xy_m + 0.01, initial_xy_m=node_xy_m, displacement_m=np.full((n, 2), 0.01),
        velocity_m_s=np.zeros((n, 2)), stress_pa=np.tile([-1.0, -2.0, -3.0, 0.5], (n, 1)), plastic_strain=np.zeros(n),
        area_m2=np.full(n, 0.5 * 0.5), mass_kg=np.full(n, 1850.0 * 0.25), density_kg_m3=np.full(n, 1850.0),
        pore_pressure_pa=np.linspace(0.0, 1e3, n), material=np.zeros(n, dtype=np.int64),
        material_names=materials.name, elem_nodes=np.array([[0, 1, 5], [0, 5, 4]], dtype=np.int64),
        spacing_m=0.5, dt_s=1e-4, critical_dt_s=2e-4,
    )
    monitors = np.array([scene.nearest_particle(m.x_m, m.y_m) for m in study.monitors], dtype=np.int64)
    series = FakeTimeSeries(n_rec=n_rec, n_mon=len(study.monitors), **series_options)
    return study, scene, final, series, monitors


@pytest.fixture
def beam_text():
    return (REPO / "studies" / "cantilever_beam.toml").read_text()


def beam_dataset(beam_text, **series_options):
    study, scene, final, series, monitors = fake_run(beam_text, **series_options)
    ds = stage_dataset(study=study, stage_index=0, series=series, final=final, monitor_particles=monitors)
    return ds, series


def test_dataset_has_the_required_variables_with_units_and_long_names(beam_text):
    ds, series = beam_dataset(beam_text)
    for name in REQUIRED_VARIABLES:
        assert name in ds.variables, name
    for name, variable in ds.variables.items():
        assert variable.attrs.get("units") is not None and variable.attrs.get("long_name"), name
    assert list(ds.monitor.values) == ["tip"]
    assert ds.monitor_ux.dims == ("monitor", "time") and ds.monitor_ux.attrs["units"] == "m"
    np.testing.assert_array_equal(ds.monitor_uy.values, series.monitor_displacement_m[:, :, 1].T)
    np.testing.assert_array_equal(ds.monitor_szz.values[0], series.monitor_stress_pa[:, 0, 2])
    assert ds.monitor_particle.values.tolist() == [11]  # (2.0, 0.2): the top right particle of the lattice
    np.testing.assert_array_equal(ds.energy_strain.values, series.energy_j_per_m[:, 1])
    assert "energy_kinetic" not in ds  # it is kinetic_energy


def test_global_attributes_carry_provenance_and_notes(beam_text):
    ds, _ = beam_dataset(beam_text)
    for name in REQUIRED_ATTRIBUTES:
        assert name in ds.attrs, name
    assert ds.attrs["study"] == beam_text
    assert ds.attrs["n_particles"] == 12 and ds.attrs["n_steps"] == 500 and ds.attrs["n_remesh"] == 2
    assert ds.attrs["note_stabilisation"] == "off (beta = 0)" and ds.attrs["note_remesh"] == "2 rebuilds"
    assert ds.attrs["stage_name"] == "vibration" and ds.attrs["stage_duration_s"] == 4.0
    assert "converged" not in ds.attrs  # dynamic stages have no convergence criterion


def test_mesh_follows_ugrid(beam_text):
    ds, _ = beam_dataset(beam_text)
    assert ds.mesh2d.attrs["cf_role"] == "mesh_topology" and ds.mesh2d.attrs["topology_dimension"] == 2
    assert ds.mesh2d.attrs["node_coordinates"] == "particle_x particle_y"
    faces = ds[ds.mesh2d.attrs["face_node_connectivity"]]
    assert faces.dims == ("face", "three") and faces.attrs["start_index"] == 0 and faces.dtype == np.int64


def test_write_round_trip_leaves_no_temporary_file(tmp_path, beam_text):
    ds, _ = beam_dataset(beam_text, converged=True)
    path = write_dataset(ds, tmp_path / "run.nc")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.nc"]
    with xr.open_dataset(path) as back:
        assert list(back.monitor.values) == ["tip"]
        assert back.attrs["converged"] == 1 and back.attrs["unbalanced_force_ratio"] == 3e-6
        assert back.attrs["study"] == beam_text
        for name, variable in back.variables.items():
            assert "units" in variable.attrs and "long_name" in variable.attrs, name
        np.testing.assert_array_equal(back.mesh2d_face_nodes.values, [[0, 1, 5], [0, 5, 4]])


def test_failed_write_leaves_nothing(tmp_path, beam_text, monkeypatch):
    ds, _ = beam_dataset(beam_text)

    def broken_write(self, store, **options):  # the file is open (and exists) by then
        raise OSError("disk full")

    monkeypatch.setattr(xr.Dataset, "dump_to_store", broken_write)
    with pytest.raises(OSError, match="disk full"):
        write_dataset(ds, tmp_path / "run.nc")
    assert list(tmp_path.iterdir()) == []


def test_a_study_without_monitors_still_writes(tmp_path, beam_text):
    text = beam_text[: beam_text.index("[[monitors]]")]
    study, scene, final, series, monitors = fake_run(text)
    ds = stage_dataset(study=study, stage_index=0, series=series, final=final, monitor_particles=monitors)
    write_dataset(ds, tmp_path / "run.nc")
    with xr.open_dataset(tmp_path / "run.nc") as back:
        assert back.sizes["monitor"] == 0 and back.sizes["time"] == 6


def test_result_paths_and_up_to_date(tmp_path, beam_text):
    study = parse_study(beam_text)
    assert result_paths(study, tmp_path) == [tmp_path / "run.nc"]
    rest = '[[stages]]\nname = "rest"\nkind = "relaxation"\nmax_duration_s = 1.0\nrecord_interval_s = 0.01\n'
    two_stages = beam_text + "\n" + rest
    assert result_paths(parse_study(two_stages), tmp_path) == [tmp_path / "vibration.nc", tmp_path / "rest.nc"]

    assert not is_up_to_date(tmp_path / "run.nc", study)
    ds, _ = beam_dataset(beam_text)
    write_dataset(ds, tmp_path / "run.nc")
    assert is_up_to_date(tmp_path / "run.nc", study)
    edited = parse_study(beam_text.replace("duration_s = 4.0", "duration_s = 2.0"))
    assert not is_up_to_date(tmp_path / "run.nc", edited)
    (tmp_path / "junk.nc").write_text("not netCDF")
    assert not is_up_to_date(tmp_path / "junk.nc", study)
