"""Writing result files so that a file with its final name is always complete.

A file is made in memory (:func:`dataset_bytes`, by the client or by a worker), written to
``<name>.tmp`` and renamed; Ctrl-C and SIGTERM wait until the file is complete or removed
(:func:`interrupts_deferred`), so an interrupted study leaves either the finished file or
nothing, and a rerun resumes from the finished ones.
"""

from __future__ import annotations

import os
import shutil
import signal
import threading
from contextlib import contextmanager
from pathlib import Path

import netCDF4
import xarray as xr
from xarray.backends import NetCDF4DataStore

from workflows.study import StudyError


@contextmanager
def interrupts_deferred():
    """Hold Ctrl-C (SIGINT) and SIGTERM back until the block ends (main thread only).

    A KeyboardInterrupt raised inside the netCDF/HDF5 writer while a file is open can leave
    its lock held and hang the clean-up.  Blocking the signal is not enough: the kernel hands
    it to another thread (dask's), and Python still raises it in the main thread.  So the
    handlers are swapped for ones that only note the signal, which is raised at the end."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    held = (signal.SIGINT, signal.SIGTERM)
    previous = {signum: signal.signal(signum, lambda signum, frame: received.append(signum)) for signum in held}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if signal.SIGINT in received:
            raise KeyboardInterrupt
        if received:
            signal.raise_signal(received[0])


def make_output_folder(out_dir: Path) -> None:
    """Create ``out_dir`` (and its parents) if needed; StudyError on ``--out`` when it cannot be."""
    try:
        Path(out_dir).mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise StudyError("--out", f"{out_dir} exists and is not a folder") from None
    except OSError as error:
        raise StudyError("--out", f"cannot make the output folder {out_dir}: {error.strerror or error}") from None


_NETCDF_WRITE_LOCK = threading.Lock()
"""Our own lock around the HDF5 calls of a serialisation (see :func:`dataset_bytes`)."""


def _hdf5_end_of_file(image: bytes) -> int:
    """Where the file in an HDF5 image ends: the "end of file address" of a version 2 or 3
    superblock with 8-byte offsets (HDF5 file format specification, section II.A: signature 8
    bytes, version, size of offsets, size of lengths, flags, then base, extension and end-of-file
    addresses), which netCDF-4 writes; the whole image for any other layout."""
    if image[:8] == b"\x89HDF\r\n\x1a\n" and image[8] in (2, 3) and image[9] == 8:
        end = int.from_bytes(image[28:36], "little")
        if 0 < end <= len(image):
            return end
    return len(image)


def dataset_bytes(ds: xr.Dataset) -> bytes:
    """``ds`` as the bytes of a netCDF-4 file, made in memory: what :func:`write_dataset` writes,
    and what a worker sends back so that the client only has to put it on disk.

    The store gets an explicit lock.  ``Dataset.to_netcdf`` picks its lock from the global dask
    configuration instead: with a dask client open it takes a ``distributed.Lock`` (a round trip
    to the scheduler) around every HDF5 call, which made a 40 ms run file take 0.3-0.9 s during
    an FOS study; and a client starting or closing in another thread changes that configuration
    in the middle of a write.  In memory, a run file takes half the time it takes on disk.  The
    image HDF5 hands back is padded past the file's end; the padding is cut off."""
    nc = netCDF4.Dataset("in-memory.nc", mode="w", format="NETCDF4", memory=1)
    try:
        ds.dump_to_store(NetCDF4DataStore(nc, lock=_NETCDF_WRITE_LOCK))
    except BaseException:
        nc.close()
        raise
    image = bytes(nc.close())
    return image[:_hdf5_end_of_file(image)]


def write_bytes(data: bytes, path: str | Path) -> Path:
    """Write ``data`` to ``path`` through ``<path>.tmp`` and a rename; no temp file survives an
    error, and an interrupt waits until the file is complete (or removed).  A folder that cannot
    take the file (full, read-only, deleted) is a StudyError on ``--out``: what was written before
    stays, and the same command resumes from it."""
    return _through_temporary(path, lambda tmp: tmp.write_bytes(data))


def share_file(source: str | Path, path: str | Path) -> Path:
    """Put the finished file ``source`` at ``path`` as a hard link to it (one copy on disk), or as
    a copy where the file system has no hard links, through ``<path>.tmp`` and a rename as
    :func:`write_bytes`.  Our files are only ever replaced by a rename, never rewritten in place, so
    a later write of either name leaves the other as it was."""
    source, path = Path(source), Path(path)
    if path.is_file() and path.samefile(source):
        return path

    def put(tmp: Path) -> None:
        try:
            os.link(source, tmp)
        except OSError:  # no hard links here (FAT, some network file systems)
            shutil.copyfile(source, tmp)

    return _through_temporary(path, put)


def _through_temporary(path: str | Path, make) -> Path:
    """``make(tmp)`` makes ``<path>.tmp``, which is then renamed to ``path`` (:func:`write_bytes`)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with interrupts_deferred():
        try:
            tmp.unlink(missing_ok=True)  # one a killed process left: a link cannot replace it
            make(tmp)
            os.replace(tmp, path)
        except OSError as error:
            try:
                tmp.unlink(missing_ok=True)
            except OSError:
                pass
            raise StudyError("--out", f"cannot write {path}: {error.strerror or error}; the files written before it "
                             "are kept: make room or fix the folder, then run the same command again to "
                             "resume") from None
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
    return path


def write_text_if_changed(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` unless it holds it already, atomically (:func:`write_bytes`)."""
    path = Path(path)
    if not (path.is_file() and path.read_text(encoding="utf-8") == text):
        write_bytes(text.encode("utf-8"), path)
    return path


def write_dataset(ds: xr.Dataset, path: str | Path) -> Path:
    """Write ``ds`` to ``path`` as a netCDF-4 file (:func:`dataset_bytes`, :func:`write_bytes`)."""
    with interrupts_deferred():
        return write_bytes(dataset_bytes(ds), path)
