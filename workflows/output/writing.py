"""Writing result files so that a file with its final name is always complete.

Every file is written to ``<name>.tmp`` and renamed; Ctrl-C and SIGTERM wait until the file
is complete or removed (:func:`interrupts_deferred`), so an interrupted study leaves either
the finished file or nothing, and a rerun resumes from the finished ones.
"""

from __future__ import annotations

import os
import signal
import threading
from contextlib import contextmanager
from pathlib import Path

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
"""Our own lock around the HDF5 calls of a write (see ``write_dataset``)."""


def write_dataset(ds: xr.Dataset, path: str | Path) -> Path:
    """Write ``ds`` to ``path`` through ``<path>.tmp`` and a rename; no temp file survives an error,
    and an interrupt waits until the file is complete (or removed).

    The store is opened with an explicit lock.  ``Dataset.to_netcdf`` picks its lock from the
    global dask configuration instead: with a dask client open it takes a ``distributed.Lock``
    (a round trip to the scheduler) around every HDF5 call, which made a 40 ms run file take
    0.3-0.9 s during an FOS study; and a client starting or closing in another thread changes
    that configuration in the middle of a write.
    """
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with interrupts_deferred():
        try:
            store = NetCDF4DataStore.open(str(tmp), mode="w", format="NETCDF4", lock=_NETCDF_WRITE_LOCK)
            try:
                ds.dump_to_store(store)
            finally:
                store.close()
            os.replace(tmp, path)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
    return path
