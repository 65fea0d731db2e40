"""ParaView files from result files: one ``.vtu`` per result, a ``.pvd`` collection per folder.

    python -m workflows.output.paraview OUT_DIR [--to DIR]

Every result file of ``OUT_DIR`` holding a particle mesh (``gravity.nc``, ``srf_<F>.nc``,
``run.nc``, ``<stage>.nc``) becomes ``<name>.vtu``: an XML UnstructuredGrid of the final
particle positions (points, z = 0) and triangles, with point data ``displacement`` (m),
``velocity`` (m s-1), ``stress`` (Pa, effective, 4 components xx, yy, zz, xy, tension positive),
``pore_pressure`` (Pa), ``plastic_strain``, ``material`` and ``initial_position`` (m); ``seepage.nc``
becomes ``seepage.vtu`` (heads, pore pressure, Darcy velocity), outside the collection.  ``results.pvd`` lists them:
SRF runs at "timestep" = F, stage files at their stage index, so ParaView's time slider
steps through the SRF values or the stages.  Data are ASCII: simple to read back and check.

During a run, ``[output] snapshot_interval_s`` makes :class:`SnapshotWriter` write the same
kind of file every interval of each stage (``OUT/paraview/<stage>_<k>.vtu`` and
``<stage>.pvd`` with the stage time).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import xarray as xr

from workflows.output.stage_file import particle_stress

VTK_TRIANGLE = 5


def _array(name: str, values: np.ndarray, components: int, vtk_type: str) -> str:
    text = " ".join(repr(float(v)) if vtk_type.startswith("Float") else str(int(v)) for v in np.ravel(values))
    return (f'<DataArray type="{vtk_type}" Name={quoteattr(name)} NumberOfComponents="{components}" '
            f'format="ascii">{text}</DataArray>')


def _unstructured_grid(xy, triangles, point_attributes: str, point_data: list[str], cell_attributes: str = "",
                       cell_data: tuple = ()) -> str:
    """The VTU text of triangles over points (n, 2) in m (z = 0), with their data arrays (``_array``
    texts) and the PointData / CellData attributes naming the default scalars and vectors."""
    n = xy.shape[0]
    triangles = np.asarray(triangles, dtype=np.int64)
    cells = [
        _array("connectivity", triangles, 1, "Int64"),
        _array("offsets", 3 * np.arange(1, triangles.shape[0] + 1), 1, "Int64"),
        _array("types", np.full(triangles.shape[0], VTK_TRIANGLE), 1, "UInt8"),
    ]
    cell_block = [f"<CellData {cell_attributes}>", *cell_data, "</CellData>"] if cell_data else []
    return "\n".join([
        '<?xml version="1.0"?>',
        '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
        "<UnstructuredGrid>",
        f'<Piece NumberOfPoints="{n}" NumberOfCells="{triangles.shape[0]}">',
        f"<PointData {point_attributes}>", *point_data, "</PointData>", *cell_block,
        "<Points>", _array("Points", np.column_stack([xy[:, 0], xy[:, 1], np.zeros(n)]), 3, "Float64"), "</Points>",
        "<Cells>", *cells, "</Cells>",
        "</Piece>", "</UnstructuredGrid>", "</VTKFile>", "",
    ])


def vtu_text(xy, triangles, displacement, velocity, stress, pore_pressure, plastic_strain, material, initial_xy) -> str:
    """The VTU text of a particle state: (n, 2) arrays in m and m/s, stress (n, 4) and pore pressure (n,) in Pa."""
    zeros = np.zeros(xy.shape[0])

    def vector(pair):
        return np.column_stack([pair[:, 0], pair[:, 1], zeros])

    point_data = [
        _array("displacement", vector(displacement), 3, "Float64"),
        _array("velocity", vector(velocity), 3, "Float64"),
        _array("stress", stress, 4, "Float64"),
        _array("pore_pressure", pore_pressure, 1, "Float64"),
        _array("plastic_strain", plastic_strain, 1, "Float64"),
        _array("material", material, 1, "Int64"),
        _array("initial_position", vector(initial_xy), 3, "Float64"),
    ]
    return _unstructured_grid(xy, triangles, 'Scalars="plastic_strain" Vectors="displacement"', point_data)


def seepage_vtu_text(ds: xr.Dataset) -> str:
    """The VTU text of a ``seepage.nc``: the particles of the flow's mesh with point data
    ``total_head`` (m), ``pressure_head`` (m), ``pore_pressure`` (Pa) and cell data
    ``darcy_velocity`` (m s-1) and ``relative_permeability``."""
    xy = np.column_stack([ds["particle_x"].values, ds["particle_y"].values])
    faces = ds.sizes["face"]
    velocity = np.column_stack([ds["darcy_vx"].values, ds["darcy_vy"].values, np.zeros(faces)])
    point_data = [_array(name, ds[name].values, 1, "Float64") for name in ("total_head", "pressure_head",
                                                                          "pore_pressure")]
    cell_data = (_array("darcy_velocity", velocity, 3, "Float64"),
                 _array("relative_permeability", ds["relative_permeability"].values, 1, "Float64"))
    return _unstructured_grid(xy, ds["mesh2d_face_nodes"].values, 'Scalars="total_head"', point_data,
                              'Vectors="darcy_velocity"', cell_data)


def dataset_to_vtu(ds: xr.Dataset) -> str:
    """The VTU text of one result dataset (module doc)."""

    def pair(a, b):
        return np.column_stack([ds[a].values, ds[b].values])

    stress = particle_stress(ds)
    n = ds["particle_x"].size
    pore_pressure = ds["particle_pore_pressure"].values if "particle_pore_pressure" in ds else np.zeros(n)
    return vtu_text(
        pair("particle_x", "particle_y"), ds["mesh2d_face_nodes"].values, pair("particle_ux", "particle_uy"),
        pair("particle_vx", "particle_vy"), stress, pore_pressure, ds["particle_plastic_strain"].values,
        ds["particle_material"].values, pair("particle_x0", "particle_y0"),
    )


def _write_text(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    tmp.replace(path)


def _pvd_text(entries) -> str:
    lines = ['<?xml version="1.0"?>', '<VTKFile type="Collection" version="1.0">', "<Collection>"]
    lines += [f'<DataSet timestep="{step!r}" part="0" file={quoteattr(name)}/>' for step, name in entries]
    return "\n".join(lines + ["</Collection>", "</VTKFile>", ""])


class SnapshotWriter:
    """Snapshots of a running stage: ``<stage>_<k>.vtu`` in ``folder`` and ``<stage>.pvd`` (time =
    stage time in s), the collection rewritten after each snapshot so an interrupted run keeps
    a usable one.  Called with each ``spfem_core.snapshot.Snapshot`` by
    ``Simulation.run(..., snapshot=(interval, writer))``."""

    def __init__(self, folder: str | Path, stage_name: str):
        self.folder = Path(folder)
        self.stage_name = stage_name
        self.entries: list[tuple[float, str]] = []
        self.folder.mkdir(parents=True, exist_ok=True)
        for old in self.folder.glob(f"{stage_name}_*.vtu"):
            old.unlink()

    def __call__(self, snapshot) -> None:
        name = f"{self.stage_name}_{len(self.entries):04d}.vtu"
        _write_text(self.folder / name, vtu_text(
            snapshot.xy_m, snapshot.elem_nodes, snapshot.displacement_m, snapshot.velocity_m_s, snapshot.stress_pa,
            snapshot.pore_pressure_pa, snapshot.plastic_strain, snapshot.material, snapshot.initial_xy_m,
        ))
        self.entries.append((float(snapshot.time_s), name))
        _write_text(self.folder / f"{self.stage_name}.pvd", _pvd_text(self.entries))


def _timestep(ds: xr.Dataset, fallback: int) -> float:
    if "srf" in ds.attrs:
        return float(ds.attrs["srf"])
    return float(ds.attrs.get("stage_index", fallback))


def export_folder(out_dir: str | Path, to: str | Path | None = None) -> Path:
    """Write ``<name>.vtu`` for every result file of ``out_dir`` and ``results.pvd``; the pvd path."""
    out_dir = Path(out_dir)
    to = Path(to) if to is not None else out_dir / "paraview"
    entries = []
    for index, path in enumerate(sorted(out_dir.glob("*.nc"))):
        with xr.open_dataset(path, engine="netcdf4") as ds:
            if "mesh2d_face_nodes" not in ds:
                continue  # summary.nc; a run file without its particle state (keep_fields)
            to.mkdir(parents=True, exist_ok=True)
            vtu = to / (path.stem + ".vtu")
            if "total_head" in ds:  # seepage.nc: the flow, beside the stages (not a step of them)
                _write_text(vtu, seepage_vtu_text(ds))
                continue
            _write_text(vtu, dataset_to_vtu(ds))
            entries.append((_timestep(ds, index), vtu.name))
    if not entries:
        raise FileNotFoundError(f"{out_dir}: no result file with a particle mesh")
    entries.sort()
    pvd = to / "results.pvd"
    _write_text(pvd, _pvd_text(entries))
    return pvd


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m workflows.output.paraview", description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", help="a study's output folder")
    parser.add_argument("--to", help="where to write (default: OUT_DIR/paraview)")
    args = parser.parse_args(argv)
    try:
        pvd = export_folder(args.out_dir, args.to)
    except FileNotFoundError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(f"wrote {pvd}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
