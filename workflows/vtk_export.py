"""ParaView files from result files: one ``.vtu`` per result, a ``.pvd`` collection per folder.

    python -m workflows.vtk_export OUT_DIR [--to DIR]

Every result file of ``OUT_DIR`` holding a particle mesh (``gravity.nc``, ``srf_<F>.nc``,
``run.nc``, ``<stage>.nc``) becomes ``<name>.vtu``: an XML UnstructuredGrid of the final
particle positions (points, z = 0) and triangles, with point data ``displacement`` (m),
``velocity`` (m/s), ``stress`` (Pa, 4 components xx, yy, zz, xy, tension positive),
``plastic_strain``, ``material`` and ``initial_position`` (m).  ``results.pvd`` lists them:
SRF runs at "timestep" = F, stage files at their stage index, so ParaView's time slider
steps through the SRF values or the stages.  Data are ASCII: simple to read back and check.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import xarray as xr

VTK_TRIANGLE = 5


def _array(name: str, values: np.ndarray, components: int, vtk_type: str) -> str:
    text = " ".join(repr(float(v)) if vtk_type.startswith("Float") else str(int(v)) for v in np.ravel(values))
    return (f'<DataArray type="{vtk_type}" Name={quoteattr(name)} NumberOfComponents="{components}" '
            f'format="ascii">{text}</DataArray>')


def dataset_to_vtu(ds: xr.Dataset) -> str:
    """The VTU text of one result dataset (module doc)."""
    x, y = ds["particle_x"].values, ds["particle_y"].values
    n = x.size
    triangles = ds["mesh2d_face_nodes"].values.astype(np.int64)
    points = np.column_stack([x, y, np.zeros(n)])
    stress = np.column_stack([ds[f"particle_s{c}"].values for c in ("xx", "yy", "zz", "xy")])
    point_data = [
        _array("displacement", np.column_stack([ds["particle_ux"].values, ds["particle_uy"].values, np.zeros(n)]), 3,
               "Float64"),
        _array("velocity", np.column_stack([ds["particle_vx"].values, ds["particle_vy"].values, np.zeros(n)]), 3,
               "Float64"),
        _array("stress", stress, 4, "Float64"),
        _array("plastic_strain", ds["particle_plastic_strain"].values, 1, "Float64"),
        _array("material", ds["particle_material"].values, 1, "Int64"),
        _array("initial_position", np.column_stack([ds["particle_x0"].values, ds["particle_y0"].values, np.zeros(n)]),
               3, "Float64"),
    ]
    cells = [
        _array("connectivity", triangles, 1, "Int64"),
        _array("offsets", 3 * np.arange(1, triangles.shape[0] + 1), 1, "Int64"),
        _array("types", np.full(triangles.shape[0], VTK_TRIANGLE), 1, "UInt8"),
    ]
    return "\n".join([
        '<?xml version="1.0"?>',
        '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
        "<UnstructuredGrid>",
        f'<Piece NumberOfPoints="{n}" NumberOfCells="{triangles.shape[0]}">',
        '<PointData Scalars="plastic_strain" Vectors="displacement">', *point_data, "</PointData>",
        "<Points>", _array("Points", points, 3, "Float64"), "</Points>",
        "<Cells>", *cells, "</Cells>",
        "</Piece>", "</UnstructuredGrid>", "</VTKFile>", "",
    ])


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
                continue  # summary.nc
            to.mkdir(parents=True, exist_ok=True)
            vtu = to / (path.stem + ".vtu")
            tmp = vtu.with_name(vtu.name + ".tmp")
            tmp.write_text(dataset_to_vtu(ds))
            tmp.replace(vtu)
            entries.append((_timestep(ds, index), vtu.name))
    if not entries:
        raise FileNotFoundError(f"{out_dir}: no result file with a particle mesh")
    entries.sort()
    lines = ['<?xml version="1.0"?>', '<VTKFile type="Collection" version="1.0">', "<Collection>"]
    lines += [f'<DataSet timestep="{step!r}" part="0" file={quoteattr(name)}/>' for step, name in entries]
    lines += ["</Collection>", "</VTKFile>", ""]
    pvd = to / "results.pvd"
    pvd.write_text("\n".join(lines))
    return pvd


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m workflows.vtk_export", description=__doc__.splitlines()[0])
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
