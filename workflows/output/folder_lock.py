"""One study at a time in an output folder: ``OUT/.spfem-fos.lock``.

Two invocations writing into one folder would mix their files (and each would take the other's
run files for stale ones).  A study takes the lock before it writes anything and gives it back
when it ends, however it ends.  The lock file names the process that holds it; a lock whose
process no longer runs on this machine (killed with -9, a crashed machine rebooted) is stale, and
the next study takes it over and says so.  A lock taken on another machine (a shared file
system) cannot be checked: the message names the machine and the file to delete.
"""

from __future__ import annotations

import json
import os
import socket
import time
from contextlib import contextmanager
from pathlib import Path

from workflows.fields import StudyError
from workflows.output.writing import make_output_folder

LOCK_NAME = ".spfem-fos.lock"


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


@contextmanager
def folder_lock(out_dir: Path, study_name: str, say=lambda text: None):
    """Hold ``out_dir``'s lock for the block (made with the folder if needed; a folder made here
    and left empty is removed again).  StudyError on ``--out`` when a running study holds it;
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
    try:
        yield
    finally:
        if (_holder(path) or {}).get("pid") == mine["pid"]:
            path.unlink(missing_ok=True)
        if made:
            try:
                out_dir.rmdir()  # only if empty: nothing was written
            except OSError:
                pass
