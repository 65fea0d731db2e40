"""What an earlier invocation of a sweep left in its folder and this one does not make again.

A sweep rerun into the same folder after it changed (fewer cases, another axis, ``figures =
false``) would leave the earlier case folders, design charts and ``threshold.nc`` beside the new
ones, looking current.  Only files spfem-fos made are removed: in a case folder that is not one of this sweep's,
its ``case.toml`` (our header), the netCDF files that carry our provenance (``spfem_fos_version``),
the figures marked as ours (``output.figures.drawn_by_us``) and our temporary files; the folder
once empty.  A file of the user's stays, and with it its folder.
"""

from __future__ import annotations

from pathlib import Path

import netCDF4

from workflows.output.figures import drawn_by_us
from workflows.sweep.results import CASE_TEXT_NAME

SWEEP_FIGURE_NAMES = ("fos_*.png", "runout_*.png", "threshold.png")
"""The design charts a sweep may draw (``sweep.figures``, and the threshold's, ``fos_time.threshold``):
those it did not draw this time are removed."""

SWEEP_RESULT_NAMES = ("threshold.nc",)
"""The result files a sweep may write besides ``study.nc`` (the threshold's, ``fos_time.threshold``): those
it did not write this time are removed (if ours: a netCDF file with our provenance)."""

CASE_TEXT_HEADERS = ("# case ", "# realisation ")
"""How the ``case.toml`` of a sweep's case and of a realisation begin (``study.reading.sweep_cases``,
``probabilistic.study_type.realisation_cases``)."""


def _made_by_us(path: Path) -> bool:
    """Whether the file ``path`` of a case folder is one spfem-fos made (module doc)."""
    if path.name.endswith(".tmp"):  # a temporary file of ours that a killed process left
        return path.name[: -len(".tmp")].endswith((".nc", ".png", ".toml"))
    if path.name == CASE_TEXT_NAME:
        try:
            return path.read_text(encoding="utf-8").startswith(CASE_TEXT_HEADERS)
        except (OSError, UnicodeDecodeError):
            return False
    if path.suffix == ".nc":
        try:
            with netCDF4.Dataset(path) as nc:
                return "spfem_fos_version" in nc.ncattrs()
        except OSError:
            return False
    return path.suffix == ".png" and drawn_by_us(path)


def remove_stale_cases(cases_dir: Path, keep: set[str]) -> tuple[list[str], list[str]]:
    """Remove the files we made in the case folders under ``cases_dir`` not named in ``keep``, and
    each folder left empty; (folders removed, folders kept because they hold files we did not make)."""
    removed, kept = [], []
    for folder in sorted(Path(cases_dir).iterdir()) if Path(cases_dir).is_dir() else []:
        if not folder.is_dir() or folder.name in keep or not (folder / CASE_TEXT_NAME).is_file():
            continue  # not a case folder of ours
        if not _made_by_us(folder / CASE_TEXT_NAME):
            kept.append(folder.name)
            continue
        for path in folder.iterdir():
            if path.is_file() and _made_by_us(path):
                path.unlink(missing_ok=True)
        try:
            folder.rmdir()  # only if empty
            removed.append(folder.name)
        except OSError:
            kept.append(folder.name)
    return removed, kept


def remove_stale_results(out_dir: Path, keep: set[str]) -> list[str]:
    """Remove the files of ``SWEEP_RESULT_NAMES`` in ``out_dir`` not named in ``keep`` that we made (a user's file
    of that name stays); their names."""
    removed = []
    for name in SWEEP_RESULT_NAMES:
        path = Path(out_dir) / name
        if name not in keep and path.is_file() and _made_by_us(path):
            path.unlink(missing_ok=True)
            removed.append(name)
    return removed


def removed_line(cases_removed: list[str], cases_kept: list[str], figures: list[str],
                 results: tuple[str, ...] | list[str] = ()) -> str | None:
    """One line saying what :func:`remove_stale_cases`, the stale figures' removal and
    :func:`remove_stale_results` did; None if nothing."""
    if not (cases_removed or cases_kept or figures or results):
        return None

    def names(items: list[str], folder: bool = False) -> str:
        shown = ", ".join(f"cases/{item}/" if folder else item for item in items[:3])
        return shown + (f" and {len(items) - 3} more" if len(items) > 3 else "")

    parts = []
    if cases_removed:
        parts.append(f"{len(cases_removed)} case folders no longer in the sweep ({names(cases_removed, True)})")
    if figures:
        parts.append(f"figures not drawn again ({names(figures)})")
    if results:
        parts.append(f"results not written again ({names(list(results))})")
    line = "removed what an earlier invocation made: " + "; ".join(parts) if parts else ""
    if cases_kept:
        line += ("; " if line else "") + (f"kept {names(cases_kept, True)}: no longer in the sweep, "
                                          "but holding files not known as made by spfem-fos")
    return line
