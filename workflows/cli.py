"""The ``spfem-fos`` command: run a study file and write its results.

    spfem-fos STUDY.toml [--out DIR] [--quiet] [--force] [--workers N | --scheduler ADDRESS] [--max-memory GIB]
    python -m workflows.cli STUDY.toml ...

A study whose last stage is ``strength_reduction`` computes a factor of safety
(:mod:`workflows.fos`: SRF runs on dask, report and ``summary.nc``), one per case with a
``[sweep]`` (:mod:`workflows.sweep`: all cases on one cluster, ``study.nc``); any other study
runs its stages in order (:mod:`workflows.stages`).

Exit codes: 0 done (or already up to date), 1 the run diverged, 2 the study cannot be run
(missing or unreadable file, invalid study or option, too large for the memory, an output
folder that cannot be made: one line on stderr, nothing written), 130 interrupted by Ctrl-C
(SIGINT) and 143 by SIGTERM: finished runs are kept, the cluster is shut down, and the same
command resumes.
"""

from __future__ import annotations

import signal
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from workflows.study import StudyError, load_study

EXIT_DIVERGED = 1
EXIT_BAD_STUDY = 2
EXIT_INTERRUPTED = 130  # Ctrl-C, as a shell reports SIGINT
EXIT_TERMINATED = 143  # SIGTERM, as a shell reports it
MAX_WORKERS = 256

app = typer.Typer(add_completion=False, pretty_exceptions_show_locals=False)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread as Ctrl-C is, so that the same clean-up runs (files
    completed or removed, the cluster shut down)."""


def _raise_terminated(signum, frame):
    raise Terminated


class StageBars:
    """A rich progress bar per stage, fed by the core's progress callback."""

    def __init__(self, progress: Progress):
        self.progress = progress
        self.tasks: dict[str, int] = {}
        self.prefix = ""  # a sweep's case, before the stage

    def __call__(self, stage, fraction: float) -> None:
        key = self.prefix + stage.name
        if key not in self.tasks:
            self.tasks[key] = self.progress.add_task(f"{key} ({stage.kind})", total=1.0)
        self.progress.update(self.tasks[key], completed=min(max(fraction, 0.0), 1.0))


def _fail(message: str, code: int) -> typer.Exit:
    typer.echo(" ".join(message.split()), err=True)
    return typer.Exit(code)


def check_output_folder(out_dir: Path) -> str | None:
    """Why ``out_dir`` cannot hold results (one line), or None: it exists as something other
    than a folder, or the nearest existing folder above it is not one we may write in."""
    if out_dir.exists() and not out_dir.is_dir():
        return f"{out_dir} exists and is not a folder"
    parent = out_dir
    while not parent.exists():
        if parent.parent == parent:
            return f"{out_dir}: no existing folder above it"
        parent = parent.parent
    if not parent.is_dir():
        return f"cannot make {out_dir}: {parent} is not a folder"
    return None


@app.command(help="Run the study file STUDY.toml and write its results (OUT/run.nc for a single stage).")
def main(
    study_file: Annotated[Path, typer.Argument(metavar="STUDY.toml", help="study file to run", show_default=False)],
    out: Annotated[
        Optional[Path], typer.Option("--out", "-o", help="output folder (default: ./<study name>)", show_default=False)
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="print only the result: the FOS line (a sweep: its table)")] = False,
    force: Annotated[bool, typer.Option("--force", help="run again even if the results are up to date")] = False,
    workers: Annotated[
        int, typer.Option("--workers", "-w", help="local dask worker processes for the SRF runs (1 thread each)")
    ] = 2,
    scheduler: Annotated[
        Optional[str],
        typer.Option("--scheduler", help="address of a running dask scheduler (tcp://host:8786) to run the SRF runs on",
                     show_default=False),
    ] = None,
    max_memory: Annotated[
        Optional[float],
        typer.Option("--max-memory", metavar="GIB", help="refuse a study whose particles would need more memory than "
                     "this (default: what the machine has available)", show_default=False),
    ] = None,
) -> None:
    try:
        study = load_study(study_file)
    except FileNotFoundError:
        raise _fail(f"error: {study_file}: no such file", EXIT_BAD_STUDY) from None
    except IsADirectoryError:
        raise _fail(f"error: {study_file}: is a folder, not a study file", EXIT_BAD_STUDY) from None
    except OSError as error:
        raise _fail(f"error: {study_file}: cannot read: {error.strerror or error}", EXIT_BAD_STUDY) from None
    except StudyError as error:
        raise _fail(f"error: {study_file}: {error}", EXIT_BAD_STUDY) from None

    if not 1 <= workers <= MAX_WORKERS:
        raise _fail(f"error: --workers: must be in [1, {MAX_WORKERS}], got {workers}", EXIT_BAD_STUDY)
    if max_memory is not None and not max_memory > 0.0:
        raise _fail(f"error: --max-memory: must be > 0 GiB, got {max_memory:g}", EXIT_BAD_STUDY)
    out_dir = Path(out) if out is not None else Path.cwd() / study.name
    problem = check_output_folder(out_dir)
    if problem:
        raise _fail(f"error: --out: {problem}", EXIT_BAD_STUDY)
    # Imported only once the study is valid, so that --help and a bad study file answer at once:
    # the core imports numba, the FOS workflow dask (about 1 s together).
    from spfem_core.divergence import DivergenceError
    from workflows.memory_guard import GIB

    max_memory_bytes = None if max_memory is None else max_memory * GIB
    console = Console(stderr=True, quiet=quiet)
    columns = (
        TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(), TimeElapsedColumn(), TimeRemainingColumn()
    )
    previous_sigterm = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        if study.sweep is not None and study.strength_reduction is None:
            _run_stage_sweep(study, out_dir, console, columns, quiet=quiet, force=force,
                             max_memory_bytes=max_memory_bytes)
        elif study.sweep is not None:
            _run_sweep(study, out_dir, console, columns, quiet=quiet, force=force, workers=workers,
                       scheduler=scheduler, max_memory_bytes=max_memory_bytes)
        elif study.strength_reduction is not None:
            _run_fos(study, study_file, out_dir, console, columns, quiet=quiet, force=force, workers=workers,
                     scheduler=scheduler, max_memory_bytes=max_memory_bytes)
        else:
            _run_stages(study, study_file, out_dir, console, columns, quiet=quiet, force=force,
                        max_memory_bytes=max_memory_bytes)
    except StudyError as error:
        raise _fail(f"error: {study_file}: {error}", EXIT_BAD_STUDY) from None
    except DivergenceError as error:
        raise _fail(f"error: {study_file}: the run diverged: {error}", EXIT_DIVERGED) from None
    except KeyboardInterrupt as interrupt:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # a second SIGTERM must not break the clean-up message
        how = "terminated (SIGTERM)" if isinstance(interrupt, Terminated) else "interrupted"
        kept = "the finished SRF runs are kept" if study.strength_reduction is not None else "finished stages are kept"
        raise _fail(f"{how}: {kept} in {out_dir}; run the same command again to resume",
                    EXIT_TERMINATED if isinstance(interrupt, Terminated) else EXIT_INTERRUPTED) from None
    finally:
        signal.signal(signal.SIGTERM, previous_sigterm)


def _run_stages(study, study_file, out_dir, console, columns, *, quiet, force, max_memory_bytes) -> None:
    from workflows.stages import run_study  # deferred, see main()

    with Progress(*columns, console=console) as progress:
        outcome = run_study(study, out_dir, progress=StageBars(progress), force=force,
                            max_memory_bytes=max_memory_bytes)
    for name in outcome.unconverged_stages:
        typer.echo(f"warning: stage {name!r} reached max_duration_s before converging (converged = 0)", err=True)
    paths = ", ".join(str(path) for path in outcome.paths)
    if outcome.up_to_date:
        typer.echo(f"{paths}: up to date with {study_file}, not run again (--force runs it)")
        return
    typer.echo(
        f"{study.name}: {outcome.n_particles} particles, {outcome.n_steps} steps of {outcome.dt_s:.3g} s, "
        f"wall time {outcome.wall_time_s:.1f} s"
    )
    if not quiet:
        typer.echo(f"wrote {paths}")


def _run_stage_sweep(study, out_dir, console, columns, *, quiet, force, max_memory_bytes) -> None:
    from workflows.sweep.report import stage_table_lines  # deferred, see main()
    from workflows.sweep.stage_cases import run_stage_sweep

    with Progress(*columns, console=console) as progress:
        bars = StageBars(progress)

        def case_started(index, n_cases, case):
            bars.prefix = f"case {index + 1}/{n_cases} {case.case_id}: "

        outcome = run_stage_sweep(study, out_dir, force=force, progress=bars, case_started=case_started,
                                  max_memory_bytes=max_memory_bytes)
    if not quiet:
        ran = sum(result.ran for result in outcome.results.values())
        typer.echo(f"{study.name}: {len(outcome.cases)} cases, {ran} run, {len(outcome.cases) - ran} up to date, "
                   f"wall time {outcome.timings_s['total']:.1f} s")
    for line in stage_table_lines(outcome):
        typer.echo(line)
    for case in outcome.cases:
        result = outcome.results[case.case_id]
        if result.message:
            typer.echo(f"warning: case {case.case_id}: {result.message}", err=True)
    if not quiet:
        typer.echo(f"wrote {outcome.study_path}, {outcome.out_dir / 'cases'}/"
                   + "".join(f", {path.name}" for path in outcome.figures))


def _fos_progress(console, columns, quiet: bool, with_cases: bool):
    """(a FosProgress that drives one rich display, the display's stop function).  The display
    starts with its first bar, so that an error before any work stays one line."""
    from workflows.fos.engine import FosProgress  # deferred, see main()

    progress = Progress(*columns, console=console)
    bars: dict[str, int] = {}
    counts = {"cases": ""}

    def bar(key: str, description: str, total: float) -> int:
        if key not in bars:
            if not bars:
                progress.start()
            bars[key] = progress.add_task(description, total=total)
        return bars[key]

    def stage(name, fraction):
        progress.update(bar(name, f"{name} (gravity)", 1.0), completed=min(max(fraction, 0.0), 1.0))

    def runs(done, planned):
        description = f"cases {counts['cases']}, SRF runs" if with_cases else "SRF runs"
        progress.update(bar("runs", description, max(planned, 1)), completed=done, total=max(planned, 1),
                        description=description)

    def cases(done, total):
        counts["cases"] = f"{done}/{total}"

    def message(text):
        if text.startswith("warning") or ": warning" in text or not quiet:
            progress.console.print(text, highlight=False, markup=False)

    def stop():
        if bars:
            progress.stop()

    return FosProgress(stage=stage, runs=runs, message=message, cases=cases), stop


def _on_cluster(run, study, out_dir, console, columns, *, quiet, with_cases, scheduler, **options):
    """``run(study, out_dir, ...)`` (a FOS study or a sweep) with its progress display; its outcome."""
    from workflows.fos.cluster import connect  # deferred until the study is valid, see main()

    if scheduler:  # before any output: an unreachable cluster is one line and exit 2
        connect(scheduler).close()
    progress, stop = _fos_progress(console, columns, quiet, with_cases=with_cases)
    try:
        return run(study, out_dir, scheduler=scheduler, progress=progress, **options)
    finally:
        stop()


def _run_fos(study, study_file, out_dir, console, columns, *, quiet, **options) -> None:
    from workflows.fos.orchestration import run_fos_study  # deferred, see main()
    from workflows.fos.report import report_lines

    outcome = _on_cluster(run_fos_study, study, out_dir, console, columns, quiet=quiet, with_cases=False, **options)
    if quiet:
        typer.echo(outcome.verdict)
        return
    typer.echo(f"{study.name}: {outcome.n_particles} particles, {len(outcome.runs)} SRF runs, "
               f"wall time {outcome.timings_s['total']:.1f} s")
    for line in report_lines(outcome):
        typer.echo(line)
    typer.echo(f"wrote {outcome.summary_path}" + "".join(f", {path.name}" for path in outcome.figures))


def _run_sweep(study, out_dir, console, columns, *, quiet, **options) -> None:
    from workflows.sweep.report import table_lines  # deferred, see main()
    from workflows.sweep.run import run_sweep

    outcome = _on_cluster(run_sweep, study, out_dir, console, columns, quiet=quiet, with_cases=True, **options)
    if not quiet:
        reused = f", {outcome.runs_reused} reused" if outcome.runs_reused else ""
        same = (f" ({len(outcome.cases) - outcome.n_distinct} identical to another)"
                if outcome.n_distinct < len(outcome.cases) else "")
        typer.echo(f"{study.name}: {len(outcome.cases)} cases{same}, {outcome.runs_made} SRF runs{reused}, "
                   f"wall time {outcome.timings_s['total']:.1f} s")
    for line in table_lines(outcome.cases, outcome.results):
        typer.echo(line)
    if not quiet:
        typer.echo(f"wrote {outcome.study_path}, {outcome.out_dir / 'cases'}/"
                   + "".join(f", {path.name}" for path in outcome.figures))


if __name__ == "__main__":
    app(prog_name="spfem-fos")
