"""The ``spfem-fos`` command: run a study file and write its results.

    spfem-fos STUDY.toml [--out DIR] [--quiet] [--force] [--workers N | --scheduler ADDRESS]
    python -m workflows.cli STUDY.toml ...

A study whose last stage is ``strength_reduction`` computes a factor of safety
(:mod:`workflows.fos`: SRF runs on dask, report and ``summary.nc``); any other study runs its
stages in order (:mod:`workflows.stages`).

Exit codes: 0 done (or already up to date), 1 the run diverged, 2 the study cannot be run
(missing file, invalid study or option: one line on stderr, nothing written), 130
interrupted (Ctrl-C) during an FOS study: finished runs are kept and a rerun resumes.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from workflows.study import StudyError, load_study

EXIT_DIVERGED = 1
EXIT_BAD_STUDY = 2
EXIT_INTERRUPTED = 130  # Ctrl-C, as a shell reports SIGINT

app = typer.Typer(add_completion=False, pretty_exceptions_show_locals=False)


class StageBars:
    """A rich progress bar per stage, fed by the core's progress callback."""

    def __init__(self, progress: Progress):
        self.progress = progress
        self.tasks: dict[str, int] = {}

    def __call__(self, stage, fraction: float) -> None:
        if stage.name not in self.tasks:
            self.tasks[stage.name] = self.progress.add_task(f"{stage.name} ({stage.kind})", total=1.0)
        self.progress.update(self.tasks[stage.name], completed=min(max(fraction, 0.0), 1.0))


def _fail(message: str, code: int) -> typer.Exit:
    typer.echo(" ".join(message.split()), err=True)
    return typer.Exit(code)


@app.command(help="Run the study file STUDY.toml and write its results (OUT/run.nc for a single stage).")
def main(
    study_file: Annotated[Path, typer.Argument(metavar="STUDY.toml", help="study file to run", show_default=False)],
    out: Annotated[
        Optional[Path], typer.Option("--out", "-o", help="output folder (default: ./<study name>)", show_default=False)
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="no progress bar and no summary")] = False,
    force: Annotated[bool, typer.Option("--force", help="run again even if the results are up to date")] = False,
    workers: Annotated[
        int, typer.Option("--workers", "-w", help="local dask worker processes for the SRF runs (1 thread each)")
    ] = 2,
    scheduler: Annotated[
        Optional[str],
        typer.Option("--scheduler", help="address of a running dask scheduler (tcp://host:8786) to run the SRF runs on",
                     show_default=False),
    ] = None,
) -> None:
    try:
        study = load_study(study_file)
    except FileNotFoundError:
        raise _fail(f"error: {study_file}: no such file", EXIT_BAD_STUDY) from None
    except OSError as error:
        raise _fail(f"error: {study_file}: cannot read: {error.strerror or error}", EXIT_BAD_STUDY) from None
    except StudyError as error:
        raise _fail(f"error: {study_file}: {error}", EXIT_BAD_STUDY) from None

    if workers < 1:
        raise _fail(f"error: --workers: must be >= 1, got {workers}", EXIT_BAD_STUDY)
    # Imported only once the study is valid, so that --help and a bad study file answer at once:
    # the core imports numba, the FOS workflow dask (about 1 s together).
    from spfem_core.divergence import DivergenceError
    from workflows.stages import run_study

    out_dir = Path(out) if out is not None else Path.cwd() / study.name
    console = Console(stderr=True, quiet=quiet)
    columns = (
        TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(), TimeElapsedColumn(), TimeRemainingColumn()
    )
    if study.strength_reduction is not None:
        _run_fos(study, study_file, out_dir, console, columns, quiet=quiet, force=force, workers=workers,
                 scheduler=scheduler)
        return
    try:
        with Progress(*columns, console=console) as progress:
            outcome = run_study(study, out_dir, progress=StageBars(progress), force=force)
    except StudyError as error:
        raise _fail(f"error: {study_file}: {error}", EXIT_BAD_STUDY) from None
    except DivergenceError as error:
        raise _fail(f"error: {study_file}: the run diverged: {error}", EXIT_DIVERGED) from None

    for name in outcome.unconverged_stages:
        typer.echo(f"warning: stage {name!r} reached max_duration_s before converging (converged = 0)", err=True)
    if quiet:
        return
    paths = ", ".join(str(path) for path in outcome.paths)
    if outcome.up_to_date:
        typer.echo(f"{paths}: up to date with {study_file}, not run again (--force runs it)")
        return
    typer.echo(
        f"{study.name}: {outcome.n_particles} particles, {outcome.n_steps} steps of {outcome.dt_s:.3g} s, "
        f"wall time {outcome.wall_time_s:.1f} s"
    )
    typer.echo(f"wrote {paths}")


def _run_fos(study, study_file, out_dir, console, columns, *, quiet, force, workers, scheduler) -> None:
    # deferred until the study is valid, see main()
    from spfem_core.divergence import DivergenceError
    from workflows.fos.cluster import connect
    from workflows.fos.orchestration import FosProgress, run_fos_study
    from workflows.fos.report import report_lines

    if scheduler:  # before any output: an unreachable cluster is one line and exit 2
        try:
            connect(scheduler).close()
        except StudyError as error:
            raise _fail(f"error: {study_file}: {error}", EXIT_BAD_STUDY) from None
    progress = Progress(*columns, console=console)
    bars: dict[str, int] = {}

    def bar(key: str, description: str, total: float) -> int:
        """The bar ``key``; the display starts with the first bar, so an early error stays one line."""
        if key not in bars:
            if not bars:
                progress.start()
            bars[key] = progress.add_task(description, total=total)
        return bars[key]

    def stage(name, fraction):
        progress.update(bar(name, f"{name} (gravity)", 1.0), completed=min(max(fraction, 0.0), 1.0))

    def runs(done, planned):
        progress.update(bar("runs", "SRF runs", max(planned, 1)), completed=done, total=max(planned, 1))

    def message(text):
        if text.startswith("warning") or not quiet:
            progress.console.print(text, highlight=False, markup=False)

    try:
        outcome = run_fos_study(
            study, out_dir, workers=workers, scheduler=scheduler, force=force,
            progress=FosProgress(stage=stage, runs=runs, message=message),
        )
    except StudyError as error:
        raise _fail(f"error: {study_file}: {error}", EXIT_BAD_STUDY) from None
    except DivergenceError as error:
        raise _fail(f"error: {study_file}: the gravity stage diverged: {error}", EXIT_DIVERGED) from None
    except KeyboardInterrupt:
        raise _fail(
            f"interrupted: the finished SRF runs are kept in {out_dir}; run the same command again to resume",
            EXIT_INTERRUPTED,
        ) from None
    finally:
        if bars:
            progress.stop()
    if quiet:
        return
    typer.echo(f"{study.name}: {outcome.n_particles} particles, {len(outcome.runs)} SRF runs, "
               f"wall time {outcome.timings_s['total']:.1f} s")
    for line in report_lines(outcome):
        typer.echo(line)
    typer.echo(f"wrote {outcome.summary_path}" + "".join(f", {path.name}" for path in outcome.figures))


if __name__ == "__main__":
    app(prog_name="spfem-fos")
