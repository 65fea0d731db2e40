"""ParaView export: the .vtu files and the .pvd collection read back to the result files' numbers."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import xarray as xr

from workflows.output.paraview import export_folder, main
from workflows.study import parse_study
from workflows.study_types import run_study


def read_vtu(path):
    piece = ET.parse(path).getroot().find("UnstructuredGrid/Piece")
    arrays = {}
    for element in piece.iter("DataArray"):
        values = np.array(element.text.split(), dtype=float)
        components = int(element.get("NumberOfComponents"))
        arrays[element.get("Name")] = values.reshape(-1, components) if components > 1 else values
    return int(piece.get("NumberOfPoints")), int(piece.get("NumberOfCells")), arrays


def test_every_run_reads_back_and_the_collection_steps_through_srf(quickstart_run, tmp_path):
    _, out, outcome = quickstart_run
    pvd = export_folder(out, tmp_path / "paraview")
    collection = ET.parse(pvd).getroot().findall("Collection/DataSet")
    files = [entry.get("file") for entry in collection]
    assert len(files) == len(outcome.runs) + 1  # gravity.nc and one per SRF run
    steps = [float(entry.get("timestep")) for entry in collection]
    assert steps == sorted(steps) and set(r.srf for r in outcome.runs) <= set(steps)
    failed = [r for r in outcome.runs if r.status == "failed"][-1]
    name = f"srf_{failed.srf:.4f}"
    n_points, n_cells, arrays = read_vtu(tmp_path / "paraview" / f"{name}.vtu")
    with xr.open_dataset(out / f"{name}.nc") as ds:
        assert n_points == ds.sizes["particle"] and n_cells == ds.sizes["face"]
        np.testing.assert_array_equal(arrays["Points"][:, 0], ds["particle_x"].values)
        np.testing.assert_array_equal(arrays["Points"][:, 1], ds["particle_y"].values)
        np.testing.assert_array_equal(arrays["connectivity"], ds["mesh2d_face_nodes"].values.ravel())
        np.testing.assert_array_equal(arrays["displacement"][:, 1], ds["particle_uy"].values)
        np.testing.assert_array_equal(arrays["stress"][:, 3], ds["particle_sxy"].values)
        np.testing.assert_array_equal(arrays["plastic_strain"], ds["particle_plastic_strain"].values)
    assert np.all(arrays["types"] == 5) and arrays["offsets"][-1] == 3 * n_cells


def test_folder_without_results_exits_2(tmp_path, capsys):
    assert main([str(tmp_path)]) == 2
    assert capsys.readouterr().err.startswith(f"error: {tmp_path}: no result file")


def test_snapshots_during_a_stage_end_on_the_final_state(tmp_path):
    text = (Path(__file__).resolve().parents[1] / "studies" / "cantilever_beam.toml").read_text()
    text = text.replace("spacing_m = 0.02", "spacing_m = 0.05").replace("duration_s = 4.0", "duration_s = 1.0")
    study = parse_study(text + "\n[output]\nsnapshot_interval_s = 0.25\n")
    run_study(study, tmp_path)
    collection = ET.parse(tmp_path / "paraview" / "vibration.pvd").getroot().findall("Collection/DataSet")
    times = [float(entry.get("timestep")) for entry in collection]
    np.testing.assert_allclose(times, [0.0, 0.25, 0.5, 0.75, 1.0], atol=1e-3)
    first = read_vtu(tmp_path / "paraview" / collection[0].get("file"))[2]
    last = read_vtu(tmp_path / "paraview" / collection[-1].get("file"))[2]
    assert np.all(first["displacement"] == 0.0)
    with xr.open_dataset(tmp_path / "run.nc") as ds:
        np.testing.assert_array_equal(last["Points"][:, 1], ds["particle_y"].values)
        np.testing.assert_array_equal(last["stress"][:, 0], ds["particle_sxx"].values)
