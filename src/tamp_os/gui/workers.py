"""The web app's decoding and conversion run in worker processes with a memory limit, so one bad
upload costs one error message, never the server.

Threads share the server's memory and its GIL: a decompression bomb that slips past the header
checks, or a pathological file that a parser chews on, would take the whole server with it. A
worker process has its own address space, capped with RLIMIT_AS: past the cap, allocation fails
with MemoryError inside the worker (reported as one message); if the worker dies anyway (killed,
crashed), its pool is replaced and the next upload gets a fresh one.

Workers start from a clean "forkserver" process, never by forking the running server (its
threads may hold locks at the moment of the fork).
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import threading
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool

from ..errors import InputError

log = logging.getLogger(__name__)

WORKERS = 2  # the machine's cores; conversions beyond that wait their turn
WORKER_MEMORY_GB = float(os.environ.get("TAMP_GUI_WORKER_GB", 2.5))  # address space of one worker
BASELINE_GB = 0.8  # a worker's own address space with NumPy, SciPy and the exporters loaded (measured 0.5)


def read_memory_gb() -> float:
    """The max_memory_gb a worker can give the reader: its cap less what the worker itself uses."""
    return max(0.1, WORKER_MEMORY_GB - BASELINE_GB)


def _limit_worker(memory_bytes: int) -> None:
    """Worker initializer: cap the address space, and end with the server (batch.exit_with_parent)."""
    import resource

    from ..lithograph.batch import exit_with_parent

    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = memory_bytes if hard == resource.RLIM_INFINITY else min(memory_bytes, hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    exit_with_parent()


PRELOAD = ["tamp_os.lithograph.pipeline", "tamp_os.lithograph.outputs", "tamp_os.export", "tamp_os.gui.jobs", "tamp_os.gui.uploads",
           "tamp_os.relief.touch"]


def _ready() -> bool:
    return True


class WorkerPool:
    """A process pool that replaces itself when a worker dies."""

    def __init__(self, workers: int = WORKERS, memory_gb: float = WORKER_MEMORY_GB):
        self.workers, self.memory_bytes = workers, int(memory_gb * 2**30)
        self._lock = threading.Lock()
        self._pool: ProcessPoolExecutor | None = None

    def _executor(self) -> ProcessPoolExecutor:
        with self._lock:
            if self._pool is None:
                if os.name == "posix":
                    context = multiprocessing.get_context("forkserver")
                    # The fork server imports the library once; each worker forks from it ready to work
                    # (importing NumPy, SciPy and the exporters in every new worker took seconds).
                    context.set_forkserver_preload(PRELOAD)
                else:
                    context = multiprocessing.get_context("spawn")
                self._pool = ProcessPoolExecutor(self.workers, mp_context=context, initializer=_limit_worker,
                                                 initargs=(self.memory_bytes,))
            return self._pool

    def warm(self) -> None:
        """Start the workers now (in the background), so the first upload does not wait for them."""
        pool = self._executor()
        for _ in range(self.workers):
            pool.submit(_ready)

    def _replace(self, broken: ProcessPoolExecutor) -> None:
        with self._lock:
            if self._pool is broken:
                self._pool = None
        broken.shutdown(wait=False, cancel_futures=True)

    def run(self, what: str, fn, *args, **kwargs):
        """`fn(*args, **kwargs)` in a worker; its result, or its TampError re-raised. A worker out of memory or
        dead becomes one InputError naming `what` (the upload's name)."""
        pool = self._executor()
        try:
            return pool.submit(fn, *args, **kwargs).result()
        except MemoryError:
            raise InputError(
                f"{what}: converting this image needs more memory than this web app gives one image "
                f"({WORKER_MEMORY_GB:g} GB). Make the image smaller (for example half as wide), or use the tamp-os command."
            ) from None
        except BrokenProcessPool:
            log.warning("a conversion worker died on %s; starting a new one", what)
            self._replace(pool)
            raise InputError(
                f"{what}: the worker converting this image stopped (it may have run out of memory). "
                "Nothing else was affected; make the image smaller and try again."
            ) from None

    def close(self) -> None:
        """Stop the workers at once (a conversion under way is abandoned: its job is being removed)."""
        with self._lock:
            pool, self._pool = self._pool, None
        if pool is not None:
            for process in list((getattr(pool, "_processes", None) or {}).values()):
                process.terminate()
            pool.shutdown(wait=False, cancel_futures=True)


_shared: WorkerPool | None = None
_shared_lock = threading.Lock()


def shared_pool() -> WorkerPool:
    """The server's one pool (made at first use)."""
    global _shared
    with _shared_lock:
        if _shared is None:
            _shared = WorkerPool()
        return _shared


def close_shared_pool() -> None:
    global _shared
    with _shared_lock:
        pool, _shared = _shared, None
    if pool is not None:
        pool.close()
