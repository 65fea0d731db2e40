"""The one place that sets numba options for every kernel of spfem_core.

Policy (see STYLE.md):
- ``cache=True``: compiled kernels are cached on disk.  numba's cache notices edits to a
  kernel's own module but not to the modules it calls, so the cache directory is keyed on a
  hash of every source file of ``spfem_core``: an edit anywhere compiles afresh.
- ``nogil=True``: kernels release the GIL (threads of a dask worker can overlap).
- ``error_model="numpy"``: division by zero gives inf/NaN instead of raising, so no
  per-division checks are compiled into the hot loop; divergence checks catch NaN.
- a fastmath *subset*: contraction, reassociation and reciprocal approximations are allowed;
  ``nnan``/``ninf`` are not, because divergence detection must see NaN and inf.
- ``no_cfunc_wrapper=True``: no C-callable wrapper per kernel (it serves kernels passed as
  first-class function values, which the core never does), and :func:`inner_kernel` for
  kernels only other kernels call: no Python entry point either.  The machine code of the
  loop is the same (bit-identical runs); a fresh process compiles about 0.6 s less
  (``warm_up`` 6.55 -> 5.94 s, median of 3 alternated runs on an empty cache each).

Threads: the kernels of the step loop run their loops over particles, elements and bonds on
numba threads (``prange`` in the small helpers :func:`parallel_inner_kernel` compiles) in a form
that gives the same bits for any number of threads.  A loop over particles writes only its own
particles, in fixed chunks of :data:`PARALLEL_CHUNK` (:func:`chunk_bounds`).  Elements and bonds,
which add into their nodes, run in blocks coloured so that blocks of one colour share no node
(``mesh.coloured_blocks``): colour after colour, the blocks of a colour at once, so that no two
threads add into one node and every node receives its terms in one order.  A loop that also
sums does so per block or chunk, and adds those sums in order afterwards; maxima and counts are
exact in any order.  On one thread the kernels run the same blocks and chunks in plain loops (a
function holding a prange costs about 3 us a call even when it starts no thread).  Which of the
two runs is decided when numba compiles, not at run time: the kernels' ``n_threads`` argument is
None for one thread (:func:`kernel_threads`), and numba drops an ``if n_threads is not None``
branch before compiling it.  A process that only ever runs one thread (a dask worker's SRF runs,
a small cloud) never compiles the threaded helpers, about 2 s of a cold start; a threaded run
compiles its own specialisation of the step.  Block and
chunk loops run an unsigned index (``range(np.uint64(start), np.uint64(end))``): with a signed
one numba adds negative-index wraparound code to every array access (the internal force was 44%
slower at 7k particles).  The loops over elements, the hottest of the step, read the particle
arrays through flat views (``array.reshape(-1)``, row i of an (n, w) array at w i + c): numba
addresses ``array[i, c]`` as i times the row length read at run time, a multiplication per array
and particle, where w i with w a constant (:data:`TWO`, :data:`FOUR`) is a shift that the arrays of
one width share (the beam at 1,111 particles: 17 instructions fewer per particle-step).
:func:`set_threads` chooses how many threads the calling thread's
kernels use (numba's threading layer: its default choice, TBB, OpenMP or its workqueue).

Set ``SPFEM_CACHE_DIR`` to choose the cache root (default ``~/.cache/spfem-fos/numba``).
Import this module before any other ``spfem_core`` module compiles (the package's
``__init__`` does).
"""

from __future__ import annotations

import functools
import hashlib
import os
from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent


@functools.lru_cache(maxsize=1)
def source_hash() -> str:
    """Short SHA-256 over the names and bytes of every ``.py`` file of spfem_core, as imported
    (read once per process: the process runs the code it imported, whatever the files say later)."""
    digest = hashlib.sha256()
    for path in sorted(_PACKAGE_DIR.rglob("*.py")):
        digest.update(path.relative_to(_PACKAGE_DIR).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def cache_dir() -> Path:
    """Numba cache directory for this exact version of the sources."""
    root = os.environ.get("SPFEM_CACHE_DIR") or Path.home() / ".cache" / "spfem-fos" / "numba"
    return Path(root) / source_hash()


# numba reads NUMBA_CACHE_DIR when it is first imported and config.CACHE_DIR when a
# dispatcher enables caching; set both so this process and the workers it starts agree.
_CACHE_DIR = cache_dir()
os.environ["NUMBA_CACHE_DIR"] = str(_CACHE_DIR)
# numba colours the message of every overload it tries and rejects while typing a kernel
# (thousands per compile, each through colorama): 0.25 s of a fresh process's compile time.
# Set NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING="" to have coloured numba errors back.
os.environ.setdefault("NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING", "1")

import numba  # noqa: E402  (must follow the environment set-up above)
import numpy as np  # noqa: E402

numba.config.CACHE_DIR = str(_CACHE_DIR)

FASTMATH_FLAGS = frozenset({"contract", "reassoc", "arcp", "nsz"})
"""Allowed fastmath flags: never ``nnan`` or ``ninf`` (NaN checks must keep working)."""

JIT_OPTIONS = dict(cache=True, nogil=True, error_model="numpy", fastmath=set(FASTMATH_FLAGS), no_cfunc_wrapper=True)


def kernel(function):
    """Compile ``function`` with the project policy: ``@kernel`` on a module-level function."""
    return numba.njit(**JIT_OPTIONS)(function)


def inner_kernel(function):
    """``@kernel`` for a function only other kernels call: no Python entry point is compiled."""
    return numba.njit(**JIT_OPTIONS, no_cpython_wrapper=True)(function)


def inline_kernel(function):
    """``@inner_kernel`` that numba copies into every kernel calling it: for the small functions
    called once per particle or bond inside a loop, where a call per item (numba leaves them as
    calls, one LLVM module per kernel) cost more than their work: the bond force as a call made
    the stabilisation loop about twice as slow."""
    return numba.njit(**JIT_OPTIONS, no_cpython_wrapper=True, inline="always")(function)


def parallel_inner_kernel(function):
    """:func:`inner_kernel` whose ``prange`` loops run on :func:`set_threads` threads (module doc)."""
    return numba.njit(**JIT_OPTIONS, parallel=True, no_cpython_wrapper=True)(function)


@inner_kernel
def fill_zero(array):
    """array[...] = 0 as one contiguous fill (C-contiguous arrays).  Compiled apart from the
    parallel kernels that use it: there a slice assignment would become a threaded loop of its
    own; an element-by-element loop was about 2 us slower per step at 1,111 particles."""
    array.reshape(-1)[:] = 0.0


ONE, TWO, FOUR = np.uint64(1), np.uint64(2), np.uint64(4)
"""Unsigned constants for the flat row offsets of the element loops (module doc): an unsigned index
mixed with a Python int would become a float in numba, or a signed index with wraparound code."""

PARALLEL_CHUNK = 512
"""Items per chunk of a parallel loop that sums (module doc).  Fixed, so that a sum's rounding
does not depend on the number of threads; large enough that the chunks' bookkeeping is
negligible, small enough that 5,000 particles make 10 chunks to share."""


@inline_kernel
def chunk_bounds(chunk, n_items):
    """(start, end) of chunk ``chunk`` of :data:`PARALLEL_CHUNK` items out of ``n_items``."""
    return chunk * PARALLEL_CHUNK, min((chunk + 1) * PARALLEL_CHUNK, n_items)


@inline_kernel
def n_chunks(n_items):
    """Chunks of :data:`PARALLEL_CHUNK` items covering ``n_items``."""
    return (n_items + PARALLEL_CHUNK - 1) // PARALLEL_CHUNK


PARTICLES_PER_THREAD = 2500
"""A run uses at most one thread per this many particles: below it, starting and joining the
threads of every loop (about 10 loops a step) costs more than sharing the loop saves (the
elastic beam at 1,111 particles: 13.0 M particle-steps/s on 1 thread, 10.3 on 2;
``python -m benchmarks.bench_core --quick`` with and without NUMBA_NUM_THREADS=1)."""


def kernel_threads(n_threads: int) -> int | None:
    """The kernels' ``n_threads`` argument for a run on ``n_threads`` threads: None for one (plain
    loops, and the threaded code is not compiled, module doc), else ``n_threads``."""
    return None if n_threads <= 1 else int(n_threads)


def set_threads(n_threads: int, n_particles: int | None = None) -> int:
    """Use ``n_threads`` threads (0: all, capped at numba's NUMBA_NUM_THREADS, the cores by
    default; and at one per :data:`PARTICLES_PER_THREAD` of ``n_particles``) in the parallel
    kernels this Python thread calls; return the number set.  Results do not depend on it
    (module doc)."""
    available = numba.config.NUMBA_NUM_THREADS
    chosen = available if n_threads <= 0 else min(int(n_threads), available)
    if n_particles is not None:
        chosen = min(chosen, max(1, n_particles // PARTICLES_PER_THREAD))
    numba.set_num_threads(chosen)
    return chosen
