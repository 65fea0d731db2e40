"""The ``spfem-fos`` command: run a study file and write its results.

    spfem-fos STUDY.toml [--out DIR] [--quiet] [--force] [--workers N | --scheduler ADDRESS] [--max-memory GIB]
    spfem-fos check STUDY.toml [--out DIR] [--workers N]
    spfem-fos --version
    python -m workflows.cli STUDY.toml ...

The study's type (:mod:`workflows.study_types`: a single study, or a ``[sweep]`` of cases) makes
its cases; a study whose last stage is ``strength_reduction`` computes a factor of safety per case
(:mod:`workflows.fos`: SRF runs on dask, report and ``summary.nc``), any other study runs its
stages in order (:mod:`workflows.stages`); a sweep brings its cases together in ``study.nc``.

Exit codes: 0 done (or already up to date), 1 the run diverged, 2 the study cannot be run
(missing or unreadable file, invalid study or option, too large for the memory, an output
folder that cannot be made, that another study holds, or that holds another study's results
without --force: one line on stderr, nothing written;
or an output folder that failed, or a cluster lost, during the run: finished runs kept), 130 interrupted by Ctrl-C
(SIGINT) and 143 by SIGTERM: finished runs are kept, the cluster is shut down, and the same
command resumes.
"""

from __future__ import annotations

import _thread
import os
import signal
import sys
import threading
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from spfem_core import __version__  # imports no numba
from spfem_core.divergence import DivergenceError  # imports no numba
from workflows.progress import Progress as StudyProgress
from workflows.study import StudyError, load_study

EXIT_DIVERGED = 1
EXIT_BAD_STUDY = 2
EXIT_INTERRUPTED = 130  # Ctrl-C, as a shell reports SIGINT
EXIT_TERMINATED = 143  # SIGTERM, as a shell reports it
MAX_WORKERS = 256
DEFAULT_WORKERS = 2
MAX_FILE_NAME_BYTES = 255  # NAME_MAX of Linux, macOS and Windows file systems

app = typer.Typer(add_completion=False, pretty_exceptions_show_locals=False)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread as Ctrl-C is, so that the same clean-up runs (files
    completed or removed, the cluster shut down)."""


def _raise_terminated(signum, frame):
    raise Terminated


RESEND_AFTER_S = 0.05
"""How long after a callback swallowed a signal it is sent again (the callback is over then)."""


class SignalsInCallbacks:
    """``sys.unraisablehook`` while a study runs.  Ctrl-C or SIGTERM raised while Python code runs
    as a callback of C code (numba compiling through llvmlite, a garbage-collector callback of
    dask's) cannot leave it: Python printed "Exception ignored in ...", numba then failed on the
    object code the callback never stored, or the study ran on to the end.  The signal is sent
    again from a thread instead, to land in the main thread once the callback is over (after
    ``RESEND_AFTER_S``); whatever else the callbacks it cut short fail with afterwards is not
    printed either (the study is ending)."""

    def __init__(self):
        self.cut_short: signal.Signals | None = None  # the signal that cut a callback short
        self.previous = sys.unraisablehook

    def __call__(self, unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            self.cut_short = signal.SIGTERM if isinstance(unraisable.exc_value, Terminated) else signal.SIGINT
            resend = threading.Timer(RESEND_AFTER_S, _thread.interrupt_main, (self.cut_short,))
            resend.daemon = True
            resend.start()
        elif self.cut_short is None:
            self.previous(unraisable)


class BarsProgress(StudyProgress):
    """The study's ``workflows.progress.Progress`` as rich progress bars on stderr: one per stage run
    in this process, one for the SRF runs (with the cases of a sweep), and the messages.  The
    display starts with its first bar, so that an error before any work stays one line."""

    def __init__(self, console: Console, quiet: bool, sweep: bool):
        columns = (TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(), TimeElapsedColumn(),
                   TimeRemainingColumn())
        self.display = Progress(*columns, console=console)
        self.quiet = quiet
        self.sweep = sweep
        self.bars: dict[str, int] = {}
        self.prefix = ""  # a sweep's case, before the stage
        self.counts = ""
        self.summary = ""  # a running tally of the cases concluded (tally)
        self.held: list[str] = []  # messages before the work starts (message)

    def _bar(self, key: str, description: str, total: float) -> int:
        if key not in self.bars:
            if not self.bars:
                self.display.start()
                self._print_held()
            self.bars[key] = self.display.add_task(description, total=total)
        return self.bars[key]

    def stage(self, case, name, kind, fraction):
        key = self.prefix + name
        self.display.update(self._bar(key, f"{key} ({kind})", 1.0), completed=min(max(fraction, 0.0), 1.0))

    def runs(self, done, planned):
        description = f"cases {self.counts}{self.summary}, SRF runs" if self.sweep else "SRF runs"
        self.display.update(self._bar("runs", description, max(planned, 1)), completed=done, total=max(planned, 1),
                            description=description)

    def cases(self, done, total):
        self.counts = f"{done}/{total}"

    def case_started(self, index, total, case_id):
        self.prefix = f"case {index + 1}/{total} {case_id}: "

    def tally(self, text):
        self.summary = f" ({text})"
        if "runs" in self.bars:
            self.display.update(self.bars["runs"], description=f"cases {self.counts}{self.summary}, SRF runs")

    def message(self, text):
        """A line of news; with --quiet only warnings.  Held until the work starts, so that a study
        refused while its scene is built prints its one error line and nothing else."""
        if self.quiet and not (text.startswith("warning") or ": warning" in text):
            return
        if self.bars:
            self._print(text)
        else:
            self.held.append(text)

    def _print(self, text):
        if self.quiet:  # the quiet console prints nothing
            typer.echo(text, err=True)
        else:
            self.display.console.print(text, highlight=False, markup=False)

    def _print_held(self):
        for text in self.held:
            self._print(text)
        self.held = []

    def stop(self, completed: bool = True):
        """The display ends; the messages still held are printed when the study ``completed``."""
        if self.bars:
            self.display.stop()
        if completed:
            self._print_held()
        self.held = []


def _fail(message: str, code: int) -> typer.Exit:
    typer.echo(" ".join(message.split()), err=True)
    return typer.Exit(code)


def check_output_folder(out_dir: Path) -> str | None:
    """Why ``out_dir`` cannot hold results (one line), or None: it exists as something other
    than a folder, or the nearest existing folder above it is not one we may write in."""
    too_long = [part for part in out_dir.parts if len(part.encode()) > MAX_FILE_NAME_BYTES]
    if too_long:
        return (f"the folder name {too_long[0][:40]}... is {len(too_long[0].encode())} bytes long, more than file "
                f"systems allow ({MAX_FILE_NAME_BYTES})")
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


def _local_workers(workers: int | None) -> int:
    """The local workers a study runs on: ``--workers`` (in [1, MAX_WORKERS], at most the cores, with a
    warning), or DEFAULT_WORKERS."""
    if workers is not None and not 1 <= workers <= MAX_WORKERS:
        raise _fail(f"error: --workers: must be in [1, {MAX_WORKERS}], got {workers}", EXIT_BAD_STUDY)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    if workers is not None and workers > cores:
        typer.echo(f"warning: --workers {workers} on {cores} cores: using {cores} (each worker runs one SRF run on "
                   "one core; more would only share the cores)", err=True)
        workers = cores
    return DEFAULT_WORKERS if workers is None else workers


def _read(study_file: Path):
    """The checked study of ``study_file``; a missing, unreadable or invalid file exits 2 with one line."""
    try:
        return load_study(study_file)
    except FileNotFoundError:
        raise _fail(f"error: {study_file}: no such file", EXIT_BAD_STUDY) from None
    except IsADirectoryError:
        raise _fail(f"error: {study_file}: is a folder, not a study file", EXIT_BAD_STUDY) from None
    except OSError as error:
        raise _fail(f"error: {study_file}: cannot read: {error.strerror or error}", EXIT_BAD_STUDY) from None
    except StudyError as error:
        raise _fail(f"error: {study_file}: {error}", EXIT_BAD_STUDY) from None


def _print_version(value: bool) -> None:
    """``--version``: the version the result files and the report carry (``spfem_core.__version__``)."""
    if value:
        typer.echo(f"spfem-fos {__version__}")
        raise typer.Exit()


@app.command(help="Run the study file STUDY.toml and write its results (OUT/run.nc for a single stage).",
             epilog="To check a study without running it (section.png, particles, memory, run time): "
             "spfem-fos check STUDY.toml [--out DIR] [--workers N]; see spfem-fos check --help.")
def main(
    study_file: Annotated[Path, typer.Argument(metavar="STUDY.toml", help="study file to run", show_default=False)],
    out: Annotated[
        str | None, typer.Option("--out", "-o", help="output folder (default: ./<study name>)", show_default=False)
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="print only the result: the FOS line (a sweep: its table)")] = False,
    force: Annotated[bool, typer.Option("--force", help="run again even if the results are up to date (and into a "
                                        "folder holding another study's results, replacing them)")] = False,
    workers: Annotated[
        int | None, typer.Option("--workers", "-w", help="local dask worker processes for the SRF runs (1 thread "
                                    "each; default 2, at most the cores)", show_default=False)
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option("--scheduler", help="a running dask scheduler to run the SRF runs on: its address "
                     "(tcp://host:8786) or its scheduler file (scheduler.json)",
                     show_default=False),
    ] = None,
    max_memory: Annotated[
        float | None,
        typer.Option("--max-memory", metavar="GIB", help="refuse a study whose particles would need more memory than "
                     "this (default: what the machine has available)", show_default=False),
    ] = None,
    version: Annotated[
        bool, typer.Option("--version", help="print the version of spfem-fos and exit", is_eager=True,
                           callback=_print_version),
    ] = False,
) -> None:
    study = _read(study_file)
    if scheduler is not None and not scheduler.strip():
        raise _fail("error: --scheduler: empty; give a scheduler's address (tcp://host:8786), or leave the option "
                    "out to run on local workers", EXIT_BAD_STUDY)
    if scheduler is not None and workers is not None:
        raise _fail("error: --workers: applies to local workers; with --scheduler the scheduler's workers run the "
                    "SRF runs (give one of the two)", EXIT_BAD_STUDY)
    workers = _local_workers(workers)
    if max_memory is not None and not max_memory > 0.0:
        raise _fail(f"error: --max-memory: must be > 0 GiB, got {max_memory:g}", EXIT_BAD_STUDY)
    if out is not None and not out.strip():
        raise _fail("error: --out: empty; give a folder (without --out: ./<study name>)", EXIT_BAD_STUDY)
    out_dir = Path(out) if out is not None else Path.cwd() / study.name
    problem = check_output_folder(out_dir)
    if problem:
        raise _fail(f"error: --out: {problem}", EXIT_BAD_STUDY)
    # Imported only once the study is valid, so that --help and a bad study file answer at once:
    # the core imports numba, the FOS workflow dask (about 1 s together).
    from workflows.cases import RunOptions
    from workflows.memory_guard import GIB
    from workflows.study_types import run_study, study_type

    options = RunOptions(workers=workers, scheduler=scheduler, force=force,
                         max_memory_bytes=None if max_memory is None else max_memory * GIB)
    kind = study_type(study, out_dir)
    progress = BarsProgress(Console(stderr=True, quiet=quiet), quiet,
                           sweep=study.sweep is not None or study.probabilistic is not None)
    previous_sigterm = signal.signal(signal.SIGTERM, _raise_terminated)
    sys.unraisablehook = signals_in_callbacks = SignalsInCallbacks()
    try:
        try:
            outcome = run_study(study, out_dir, options, progress, kind)
        except BaseException:
            progress.stop(completed=False)
            raise
        progress.stop()
        report = kind.report(outcome, quiet, study_file)
        for line in report.warnings:
            typer.echo(line, err=True)
        for line in report.lines:
            typer.echo(line)
        from workflows.html_report import write_html_report  # xarray: this module imports none of it

        page = write_html_report(kind, outcome, study_file)
        if not quiet:
            typer.echo(f"report: {page}")
    except StudyError as error:
        raise _fail(f"error: {study_file}: {error}", EXIT_BAD_STUDY) from None
    except DivergenceError as error:
        raise _fail(f"error: {study_file}: the run diverged: {error}", EXIT_DIVERGED) from None
    except OSError as error:  # a failing file or folder (full, read-only, deleted), a lost cluster (ClusterLost)
        where = f"{error.filename}: " if error.filename else ""
        raise _fail(f"error: {study_file}: {where}{error.strerror or error}; the finished runs are kept in {out_dir}; "
                    "fix the cause and run the same command again to resume", EXIT_BAD_STUDY) from None
    except EOFError as error:  # a pipe to a worker or the forkserver closed: click would call it Ctrl-C
        raise _fail(f"error: {study_file}: a worker process's connection closed unexpectedly (EOFError{': ' if str(error) else ''}"
                    f"{error}); the finished runs are kept in {out_dir}; run the same command again to resume",
                    EXIT_BAD_STUDY) from None
    except (KeyboardInterrupt, Exception) as interrupt:
        if not isinstance(interrupt, KeyboardInterrupt) and signals_in_callbacks.cut_short is None:
            raise
        terminated = isinstance(interrupt, Terminated) or signals_in_callbacks.cut_short == signal.SIGTERM
        # what a signal cut short in a callback made fail is the interruption too; a second signal
        # (or the one sent again) must not break the clean-up message
        previous_sigint = signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        how = "terminated (SIGTERM)" if terminated else "interrupted"
        kept = "the finished SRF runs are kept" if study.strength_reduction is not None else "finished stages are kept"
        failure = _fail(f"{how}: {kept} in {out_dir}; run the same command again to resume",
                        EXIT_TERMINATED if terminated else EXIT_INTERRUPTED)
        signal.signal(signal.SIGINT, previous_sigint)
        raise failure from None
    finally:
        signal.signal(signal.SIGTERM, previous_sigterm)
        sys.unraisablehook = signals_in_callbacks.previous


check_app = typer.Typer(add_completion=False, pretty_exceptions_show_locals=False)


@check_app.command(help="Check the study file STUDY.toml without running it: every check the run makes before its "
                   "first step, its scene built, the section drawn to OUT/section.png, and the particles, memory and "
                   "run time estimated.")
def check(
    study_file: Annotated[Path, typer.Argument(metavar="STUDY.toml", help="study file to check", show_default=False)],
    out: Annotated[
        str | None, typer.Option("--out", "-o", help="output folder (default: ./<study name>)", show_default=False)
    ] = None,
    workers: Annotated[
        int | None, typer.Option("--workers", "-w", help="local workers the study would run on (default 2, at most "
                                    "the cores)", show_default=False)
    ] = None,
    max_memory: Annotated[
        float | None,
        typer.Option("--max-memory", metavar="GIB", help="the memory limit the study would run with (default: what "
                     "the machine has available)", show_default=False),
    ] = None,
) -> None:
    study = _read(study_file)
    if out is not None and not out.strip():
        raise _fail("error: --out: empty; give a folder (without --out: ./<study name>)", EXIT_BAD_STUDY)
    if max_memory is not None and not max_memory > 0.0:
        raise _fail(f"error: --max-memory: must be > 0 GiB, got {max_memory:g}", EXIT_BAD_STUDY)
    workers = _local_workers(workers)
    out_dir = Path(out) if out is not None else Path.cwd() / study.name
    problem = check_output_folder(out_dir)
    if problem:
        raise _fail(f"error: --out: {problem}", EXIT_BAD_STUDY)
    # Imported only once the study is valid, as for a run (numba, scipy, xarray, dask).
    from workflows.cases import RunOptions
    from workflows.check import check_study
    from workflows.memory_guard import GIB
    from workflows.output.folder_lock import check_folder_study, study_digest
    from workflows.study_types import study_type

    options = RunOptions(workers=workers, max_memory_bytes=None if max_memory is None else max_memory * GIB)
    try:
        check_folder_study(out_dir, study.name, False, study_digest(study))  # as the run refuses it
        result = check_study(study, study_type(study, out_dir), out_dir, options)
    except StudyError as error:
        raise _fail(f"error: {study_file}: {error}", EXIT_BAD_STUDY) from None
    except OSError as error:
        raise _fail(f"error: --out: {error.filename or out_dir}: {error.strerror or error}", EXIT_BAD_STUDY) from None
    for line in result.lines():
        typer.echo(line)


def run() -> None:
    """The ``spfem-fos`` command (its console entry point): the app, or with ``check`` first the
    check of a study (:func:`check`), with a usage error (a missing study file, an unknown option)
    as one line and exit code 2."""
    arguments = sys.argv[1:]
    checking = arguments[:1] == ["check"]
    try:
        if checking:
            code = check_app(args=arguments[1:], prog_name="spfem-fos check", standalone_mode=False)
        else:
            code = app(prog_name="spfem-fos", standalone_mode=False)
    except typer.Abort:  # Ctrl-C while the command line is read
        raise SystemExit(EXIT_INTERRUPTED) from None
    except Exception as error:
        # click's UsageError (typer ships its own copy of click): exit code 2 and a message
        if getattr(error, "exit_code", None) != 2 or not hasattr(error, "format_message"):
            raise
        hint = "spfem-fos check --help" if checking else "spfem-fos --help"
        typer.echo(f"error: {' '.join(error.format_message().split())} ({hint})", err=True)
        raise SystemExit(EXIT_BAD_STUDY) from None
    raise SystemExit(code or 0)


if __name__ == "__main__":
    run()
