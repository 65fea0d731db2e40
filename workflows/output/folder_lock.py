"""One study at a time in an output folder: ``OUT/.spfem-fos.lock``.

Two invocations writing into one folder would mix their files (and each would take the other's
run files for stale ones).  A study takes the lock before it writes anything and gives it back
when it ends, however it ends.  The lock file names the process that holds it; a lock whose
process no longer runs on this machine (killed with -9, a crashed machine rebooted) is stale, and
the next study takes it over and says so.  A lock taken on another machine (a shared file
system) cannot be checked: the message names the machine and the file to delete.

One study per output folder, too: ``OUT/.spfem-fos.study`` names the study whose results the
folder holds, with a digest of what it computes (all of it but its ``[study]`` table).  The same
study run again resumes and reuses what still applies (and removes what it no longer makes),
whether it was changed (the same name) or renamed (the same digest); another study, of another
name and digest, is refused before it removes anything, unless ``--force`` (``spfem-fos check``
refuses it alike).  A folder written before this file existed is known by the first result file
of ours at its top: its ``study_name`` and the study text it carries.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import socket
import time
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

import netCDF4

from workflows.fields import StudyError
from workflows.output.writing import make_output_folder, write_bytes
from workflows.study import StudyError as Invalid
from workflows.study import parse_study

LOCK_NAME = ".spfem-fos.lock"
STUDY_NAME_FILE = ".spfem-fos.study"


def _running(pid: int) -> bool:
    """Whether process ``pid`` exists on this machine."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, another user's
        return True
    return True


def _holder(path: Path) -> dict | None:
    """The lock's content; None when it cannot be read (a lock being written or removed)."""
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


class FolderStudy(NamedTuple):
    """The study whose results a folder holds: its name, and the digest of what it computes
    (:func:`study_digest`; None where it is not known)."""

    name: str
    digest: str | None


def study_digest(study) -> str:
    """A hash of what ``study`` computes: all of it but its ``[study]`` table (name, description,
    which change no number) and its text.  A study renamed and nothing else has the same digest."""
    raw = dataclasses.asdict(study)
    for key in ("source_text", "study"):
        raw.pop(key, None)
    return hashlib.sha256(json.dumps(raw, sort_keys=True, default=str).encode()).hexdigest()[:24]


def folder_study(out_dir: Path) -> FolderStudy | None:
    """The study whose results ``out_dir`` holds (module doc): as its ``STUDY_NAME_FILE`` names it,
    else as the first result file of ours at its top does (its name, and the digest of the study
    text it carries if that still reads); None if none is known."""
    try:
        marked = json.loads((Path(out_dir) / STUDY_NAME_FILE).read_text())
        return FolderStudy(str(marked["study"]), marked.get("digest"))
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        pass


    for path in sorted(Path(out_dir).glob("*.nc")):
        try:
            with netCDF4.Dataset(path) as nc:
                attrs = {name: nc.getncattr(name) for name in nc.ncattrs()}
        except OSError:
            continue
        if "spfem_fos_version" in attrs and "study_name" in attrs:
            try:
                digest = study_digest(parse_study(str(attrs.get("study", ""))))
            except (Invalid, ValueError):
                digest = None
            return FolderStudy(str(attrs["study_name"]), digest)
    return None


def check_folder_study(out_dir: Path, study_name: str, force: bool, digest: str | None = None) -> None:
    """StudyError on ``--out`` when ``out_dir`` holds another study's results (another name, and not
    the same study renamed: another digest) and ``force`` is not set."""
    held = folder_study(out_dir) if Path(out_dir).is_dir() else None
    if held is None or force or held.name == study_name or (digest is not None and held.digest == digest):
        return
    raise StudyError("--out", f"{out_dir} holds the results of study {held.name!r}, and this is study "
                     f"{study_name!r}: its runs would replace them; give another --out, or --force to "
                     "replace them")


@contextmanager
def folder_lock(out_dir: str | Path, study_name: str, say=lambda text: None, force: bool = False,
                digest: str | None = None):
    """Hold ``out_dir``'s lock for the block (made with the folder if needed; a folder made here
    and left empty is removed again), and mark the folder as the study's (``study_name``, and its
    ``digest``, :func:`study_digest`).  StudyError on ``--out`` when a running study holds it, or
    when it holds another study's results and ``force`` is not set (:func:`check_folder_study`);
    ``say(text)`` reports a stale lock taken over."""
    out_dir = Path(out_dir)
    made = not out_dir.exists()
    make_output_folder(out_dir)
    path = out_dir / LOCK_NAME
    mine = {"pid": os.getpid(), "host": socket.gethostname(), "study": study_name,
            "started": time.strftime("%Y-%m-%d %H:%M:%S")}
    for _attempt in range(3):
        try:
            descriptor = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            holder = _holder(path)
            if holder is None:
                time.sleep(0.1)
                continue
            if holder.get("host") != mine["host"]:
                raise StudyError("--out", f"{out_dir} is in use by study {holder.get('study')!r} on "
                                 f"{holder.get('host')} (pid {holder.get('pid')}, since {holder.get('started')}); "
                                 f"choose another folder, or delete {path} if nothing runs there") from None
            if _running(int(holder.get("pid", -1))):
                raise StudyError("--out", f"{out_dir} is in use by study {holder.get('study')!r} (pid "
                                 f"{holder.get('pid')}, since {holder.get('started')}); wait for it to end or "
                                 "choose another folder") from None
            say(f"took over the lock of {out_dir} left by study {holder.get('study')!r} (pid {holder.get('pid')}, "
                f"since {holder.get('started')}), which no longer runs")
            path.unlink(missing_ok=True)
            continue
        except OSError as error:
            raise StudyError("--out", f"cannot write in {out_dir}: {error.strerror or error}") from None
        with os.fdopen(descriptor, "w") as lock:
            json.dump(mine, lock)
        break
    else:
        raise StudyError("--out", f"{out_dir}: could not take its lock {path}; another study is starting there")
    study_file = out_dir / STUDY_NAME_FILE
    try:
        check_folder_study(out_dir, study_name, force, digest)
        if folder_study(out_dir) != (study_name, digest):
            write_bytes(json.dumps({"study": study_name, "digest": digest}).encode(), study_file)
        yield
    finally:
        if (_holder(path) or {}).get("pid") == mine["pid"]:
            path.unlink(missing_ok=True)
        if made:
            try:
                if [p.name for p in out_dir.iterdir()] == [STUDY_NAME_FILE]:
                    study_file.unlink()
                out_dir.rmdir()  # only if empty: nothing was written
            except OSError:
                pass
