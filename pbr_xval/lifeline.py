"""Worker processes die with the process that started them: no orphan outlives a killed parent.

A ``kill -9`` (or a plain SIGTERM, whose default action also skips every ``finally``) of a
driver leaves its worker processes to the init process: a process pool's workers block on a
queue whose writer is gone, or go on computing their chunk. Every worker pbr-xval starts calls
:func:`die_with_parent` first:

* on Linux, ``prctl(PR_SET_PDEATHSIG, SIGKILL)``: the kernel kills the worker as soon as the
  thread that started it ends, which for our pools is the driver's main thread (or the
  thread that owns the pool for its whole life), so the death of the driver kills it at once,
  even inside a long C call that holds the GIL;
* then ``os.getppid()`` is compared with the driver's pid: a driver that died before the
  ``prctl`` call took effect would otherwise never signal this worker;
* elsewhere (no ``prctl``), a daemon thread polls ``os.getppid()`` every 0.2 s.

With the workers gone, the ``multiprocessing`` resource tracker exits by itself: it reads a
pipe whose write ends only the driver and its workers hold, and exits on end-of-file.

Dask's ``LocalCluster`` workers get the same through :func:`dask_setup` (this module is a Dask
worker preload; see :func:`dask_preload_config`); Dask's own parent-pipe watch exits them too.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time

__all__ = ["PARENT_ENV", "dask_preload_config", "dask_setup", "die_with_parent"]

#: environment variable naming the driver's pid, for workers that cannot take an argument
PARENT_ENV = "PBR_XVAL_PARENT_PID"

_PR_SET_PDEATHSIG = 1


def _set_pdeathsig() -> bool:
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return int(libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False


def _watch_parent(parent_pid: int) -> None:
    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(0.2)
        os._exit(1)

    threading.Thread(target=watch, name="pbr-xval parent watch", daemon=True).start()


def die_with_parent(parent_pid: int | None = None) -> None:
    """Make this (worker) process die when ``parent_pid`` (default: the current parent) dies.

    Call it first thing in the worker (a pool's ``initializer``). If the parent is already
    gone, the process exits here.
    """
    if parent_pid is None:
        env = os.environ.get(PARENT_ENV, "")
        parent_pid = int(env) if env.isdigit() else os.getppid()
    if not _set_pdeathsig():
        _watch_parent(parent_pid)
    if os.getppid() != parent_pid:  # the parent died before the prctl call: nobody will signal us
        os._exit(1)


def dask_setup(worker: object = None) -> None:
    """Dask worker preload hook: the worker process dies with the process that started it."""
    with contextlib.suppress(ValueError):
        die_with_parent()


def dask_preload_config() -> dict[str, object]:
    """``dask.config`` entries that preload this module into every worker a LocalCluster starts."""
    return {"distributed.worker.preload": [__name__]}
