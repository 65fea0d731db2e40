"""The notebooks in studies/notebooks run top to bottom (nbclient): the results notebook on a
fresh quickstart result, the sweep notebook on a fresh sweep, the benchmark notebook on the
committed bench_results tables."""

from __future__ import annotations

from pathlib import Path

import nbformat
from nbclient import NotebookClient

NOTEBOOK_DIR = Path(__file__).resolve().parents[1] / "studies" / "notebooks"


def run_notebook(path: Path):
    notebook = nbformat.read(path, as_version=4)
    NotebookClient(notebook, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}}).execute()
    return "".join(
        output.get("text", "") for cell in notebook.cells if cell.cell_type == "code" for output in cell.outputs
    )


def test_results_notebook_runs_on_the_quickstart_results(quickstart_run, monkeypatch):
    _, out, outcome = quickstart_run
    monkeypatch.setenv("SPFEM_RESULTS", str(out))
    assert f"FOS {outcome.fos:.4f}" in run_notebook(NOTEBOOK_DIR / "fos_results.ipynb")


def test_sweep_notebook_runs_on_the_strength_sweep(strength_sweep, monkeypatch):
    _, out, outcome = strength_sweep
    monkeypatch.setenv("SPFEM_RESULTS", str(out))
    printed = run_notebook(NOTEBOOK_DIR / "sweep_results.ipynb")
    assert "sweep_strength: 9 cases over cohesion_pa, friction_deg" in printed
    below = sum(r.status == "found" and r.fos < 1.0 for r in outcome.results.values())
    assert f"{below} of 9 cases have FOS < 1" in printed


def test_benchmark_notebook_runs_on_the_committed_tables():
    tables = sorted(p.stem for p in (NOTEBOOK_DIR.parents[1] / "bench_results").glob("*/*.nc"))
    assert "beam" in tables
    printed = run_notebook(NOTEBOOK_DIR / "benchmarks.ipynb")
    assert all(f"{name} {{" in printed for name in tables), printed[:300]


def test_every_notebook_is_tested():
    assert sorted(p.name for p in NOTEBOOK_DIR.glob("*.ipynb")) == ["benchmarks.ipynb", "fos_results.ipynb", "sweep_results.ipynb"]
