"""Run a chunk list: local process pool, Dask, or a shard of it; resume; crash containment.

* ``local`` — ``concurrent.futures.ProcessPoolExecutor`` (spawn context). A worker that dies
  (segfault, abort) breaks the pool: the pool is recreated and every chunk that was in flight
  is re-run alone in a fresh one-process pool, so the culprit is identified exactly; a chunk
  that crashes again is recorded as failed (with the reason) and the sweep goes on.
* ``dask`` — a ``distributed.LocalCluster`` (processes, one thread per worker) or an existing
  scheduler (``scheduler="tcp://..."``). ``distributed.scheduler.allowed-failures`` is 1 for the
  local cluster: a task whose worker dies is retried once, then ``KilledWorker`` marks it failed.
* ``shard="i/N"`` — only every N-th chunk of the deterministic list (1-based i), for job arrays.

Each chunk is written by the worker that ran it (see :mod:`pbr_xval.catalog.store`); chunks
whose file already exists with a matching hash are skipped (resume).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import json
import multiprocessing as mp
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pbr_xval.catalog import store
from pbr_xval.catalog.tasks import ChunkSpec, build_chunks, execute_chunk, shard_chunks
from pbr_xval.lifeline import PARENT_ENV, dask_preload_config, die_with_parent

__all__ = ["LocalPool", "SweepSummary", "run_chunks", "run_sweep"]


@dataclass
class SweepSummary:
    total: int = 0
    done: int = 0
    skipped: int = 0
    failed: int = 0
    simulations: int = 0
    wall_s: float = 0.0
    compute_s: float = 0.0
    write_s: float = 0.0
    sim_s: float = 0.0
    peak_rss_mb: dict[int, float] = field(default_factory=dict)
    failures: list[dict[str, str]] = field(default_factory=list)
    dashboard: str | None = None
    #: runs in the chunks done whose status is not ok (failed, timeout, ...): progress lines
    runs_not_ok: int = 0

    @property
    def sims_per_s(self) -> float:
        return self.simulations / self.wall_s if self.wall_s > 0 else 0.0

    def to_dict(self) -> dict[str, Any]:
        return {
            "chunks_total": self.total, "chunks_done": self.done, "chunks_skipped": self.skipped,
            "chunks_failed": self.failed, "simulations": self.simulations, "wall_s": self.wall_s,
            "core_s": self.compute_s, "write_s": self.write_s, "sim_s": self.sim_s,
            "sims_per_s": self.sims_per_s, "peak_rss_mb_per_worker": max(self.peak_rss_mb.values(), default=0.0),
            "failures": self.failures, "dashboard": self.dashboard,
        }  # fmt: skip

    def fail(self, spec: ChunkSpec, reason: str) -> None:
        """Count ``spec`` as failed, with its record (chunk hash, rock, engine, reason); both executors."""
        self.failed += 1
        self.failures.append(
            {"chunk": spec.content_hash(), "rock": spec.rock["id"], "engine": spec.engine, "reason": reason}
        )

    def add(self, res: dict[str, Any]) -> None:
        if res.get("skipped"):
            self.skipped += 1
        else:
            self.done += 1
            self.simulations += int(res["n"])
            self.compute_s += float(res["compute_s"])
            self.write_s += float(res["write_s"])
            self.sim_s += float(res.get("sim_s", 0.0))
            self.runs_not_ok += int(res.get("not_ok", 0))
        pid = int(res.get("pid", 0))
        self.peak_rss_mb[pid] = max(self.peak_rss_mb.get(pid, 0.0), float(res.get("rss_mb", 0.0)))


@contextlib.contextmanager
def _thread_env() -> Iterator[None]:
    """OMP_NUM_THREADS=1 (and friends) for worker processes started inside the block."""
    keys = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
    old = {k: os.environ.get(k) for k in keys}
    for k in keys:
        os.environ[k] = "1"
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _init_worker(parent_pid: int | None = None) -> None:
    die_with_parent(parent_pid)  # no orphan when the driver is killed
    for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[k] = "1"
    # the store's writer: imported once per worker, not on the first chunk's clock
    import pyarrow.parquet  # noqa: F401


def _crash_reason(exc: BaseException) -> str:
    return f"worker process died while running the chunk ({type(exc).__name__}: {exc})"


# ------------------------------------------------------------------ local
def _run_isolated(spec_json: str, out: str) -> tuple[dict[str, Any] | None, str | None]:
    ctx = mp.get_context("spawn")
    with cf.ProcessPoolExecutor(
        max_workers=1, mp_context=ctx, initializer=_init_worker, initargs=(os.getpid(),)
    ) as pool:
        fut = pool.submit(execute_chunk, spec_json, out)
        try:
            return fut.result(), None
        except cf.process.BrokenProcessPool as exc:
            return None, _crash_reason(exc)
        except Exception as exc:
            return None, f"{type(exc).__name__}: {exc}"


def _new_pool(workers: int) -> cf.ProcessPoolExecutor:
    return cf.ProcessPoolExecutor(
        max_workers=workers, mp_context=mp.get_context("spawn"), initializer=_init_worker,
        initargs=(os.getpid(),),
    )  # fmt: skip


class LocalPool:
    """A local process pool kept across several :func:`run_chunks` calls (``pool=``).

    The adaptive ensemble runs one batch of members after another: with one pool its worker
    processes start (spawn, imports, the store's writer) once, and keep what they cache (engine
    instances, compiled models), instead of once per batch. A pool broken by a crashing worker
    is replaced (:meth:`renew`). Use as a context manager; it shuts the workers down on exit.
    """

    def __init__(self, workers: int | None = None) -> None:
        self.workers = int(workers or max(1, (os.cpu_count() or 1)))
        self._pool: cf.ProcessPoolExecutor | None = None

    def get(self) -> cf.ProcessPoolExecutor:
        if self._pool is None:
            self._pool = _new_pool(self.workers)
        return self._pool

    def renew(self) -> cf.ProcessPoolExecutor:
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = None
        return self.get()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def __enter__(self) -> LocalPool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _local(
    todo: list[ChunkSpec], out: str, workers: int, summary: SweepSummary, tick: Callable[[], None],
    shared: LocalPool | None = None,
) -> None:  # fmt: skip
    queue = list(todo)
    if shared is not None:
        workers = shared.workers
    window = 2 * workers
    suspects: list[ChunkSpec] = []
    pool = shared.get() if shared is not None else _new_pool(workers)
    running: dict[cf.Future[dict[str, Any]], ChunkSpec] = {}
    try:
        while queue or running:
            while queue and len(running) < window:
                spec = queue.pop(0)
                running[pool.submit(execute_chunk, spec.to_json(), out)] = spec
            done, _ = cf.wait(running, return_when=cf.FIRST_COMPLETED)
            broken = False
            for fut in done:
                spec = running.pop(fut)
                try:
                    summary.add(fut.result())
                    tick()
                except cf.process.BrokenProcessPool:
                    broken = True
                    suspects.append(spec)
                except Exception as exc:  # an exception escaping execute_chunk (e.g. disk full)
                    summary.fail(spec, f"{type(exc).__name__}: {exc}")
                    tick()
            if broken:
                # every chunk still in the pool is lost with it: collect and re-run alone
                for fut, spec in list(running.items()):
                    try:
                        summary.add(fut.result(timeout=30))
                        tick()
                    except Exception:
                        suspects.append(spec)
                running.clear()
                if shared is None:  # (a shared pool is shut down by renew() below)
                    pool.shutdown(wait=False, cancel_futures=True)
                with cf.ThreadPoolExecutor(max_workers=workers) as tp:
                    results = list(tp.map(lambda s: (s, _run_isolated(s.to_json(), out)), suspects))
                suspects = []
                for spec, (res, reason) in results:
                    if res is not None:
                        summary.add(res)
                    else:
                        summary.fail(spec, f"failed twice; {reason}")
                    tick()
                pool = shared.renew() if shared is not None else _new_pool(workers)
    finally:
        if shared is None:
            pool.shutdown(wait=True, cancel_futures=True)


# ------------------------------------------------------------------ dask
def _dask(
    todo: list[ChunkSpec], out: str, workers: int, scheduler: str | None, summary: SweepSummary,
    tick: Callable[[], None], say: Callable[[str], None],
) -> None:  # fmt: skip
    try:
        import dask
        from distributed import Client, KilledWorker, LocalCluster, as_completed
    except ImportError as exc:  # pragma: no cover
        raise RuntimeError("the dask executor needs: pip install 'pbr-xval[dask]'") from exc

    cluster = None
    # worker-saturation 1.0: a worker holds one chunk per thread, so a worker that a bad chunk
    # kills takes no queued healthy chunk with it (with allowed-failures = 1 a healthy chunk
    # caught on two dying workers would be reported as failed). A scheduler given by address
    # keeps its own configuration.
    conf: dict[str, Any] = {
        "distributed.scheduler.allowed-failures": 1,
        "distributed.scheduler.worker-saturation": 1.0,
        "distributed.worker.daemon": False,
    }
    if not scheduler:  # the workers we start die with this process (pbr_xval.lifeline)
        conf.update(dask_preload_config())
    with dask.config.set(conf):
        if scheduler:
            client = Client(scheduler)
        else:
            env = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
            env[PARENT_ENV] = str(os.getpid())
            if os.environ.get("PYTHONPATH"):
                env["PYTHONPATH"] = os.environ["PYTHONPATH"]
            cluster = LocalCluster(
                n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0", env=env
            )
            client = Client(cluster)
        try:
            summary.dashboard = client.dashboard_link
            say(f"Dask dashboard: {client.dashboard_link}")
            futs = {}
            for spec in todo:
                f = client.submit(
                    execute_chunk, spec.to_json(), out, key=f"chunk-{spec.content_hash()}", pure=False
                )
                futs[f] = spec
            for f in as_completed(list(futs)):
                spec = futs[f]
                try:
                    summary.add(f.result())
                except KilledWorker as exc:
                    summary.fail(spec, f"worker died twice running the chunk (KilledWorker: {exc})")
                except Exception as exc:
                    summary.fail(spec, f"{type(exc).__name__}: {exc}")
                tick()
        finally:
            client.close()
            if cluster is not None:
                cluster.close()


# ------------------------------------------------------------------ driver
#: off a terminal, a progress line at least every this many seconds, and at every 5 % done
PLAIN_PROGRESS_S = 10.0


class _PlainProgress:
    """Progress as plain lines when the console is not a terminal (``validate: 37/196 done, 0
    chunks failed, 1 runs not ok, 41 s, ETA 95 s``), every :data:`PLAIN_PROGRESS_S` seconds and
    at every 5 % done."""

    def __init__(self, say: Callable[[str], None], label: str, total: int, summary: SweepSummary) -> None:
        self.say, self.label, self.total, self.summary = say, label, total, summary
        self.t0 = self.last = time.monotonic()
        self.ran = 0
        self.step = -1

    def start(self, todo: int) -> None:
        self.say(
            f"{self.label}: {self.total} chunks, {self.total - todo} already in the store, {todo} to run"
        )

    def tick(self) -> None:
        self.ran += 1
        done = self.summary.skipped + self.ran
        now = time.monotonic()
        step = 20 * done // max(1, self.total)
        if now - self.last < PLAIN_PROGRESS_S and step == self.step and done < self.total:
            return
        self.last, self.step = now, step
        el = now - self.t0
        left = self.total - done
        eta = f"ETA {el / self.ran * left:.0f} s" if left else "finished"
        bad = f"{self.summary.failed} chunks failed, {self.summary.runs_not_ok} runs not ok"
        self.say(f"{self.label}: {done}/{self.total} done, {bad}, {el:.0f} s, {eta}")


def run_chunks(
    chunks: list[ChunkSpec],
    out: str | Path,
    *,
    executor: str = "local",
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
    console: Any = None,
    description: str = "chunks",
    pool: LocalPool | None = None,
) -> SweepSummary:
    """Run ``chunks`` into the store at ``out`` (skipping finished ones); returns a summary.

    ``pool``: the local executor's worker processes, kept by the caller across calls
    (:class:`LocalPool`; its worker count then applies); by default a pool per call.
    """
    out = str(Path(out))
    Path(out).mkdir(parents=True, exist_ok=True)
    workers = int(workers or max(1, (os.cpu_count() or 1)))
    summary = SweepSummary(total=len(chunks))
    t0 = time.perf_counter()
    todo = []
    for c in chunks:  # resume: skip without starting a worker
        if store.chunk_done(out, c):
            summary.skipped += 1
        else:
            todo.append(c)

    if console is None and progress:
        from pbr_xval.console import make_console

        console = make_console(stderr=True)
    # one log line per message: a console that is not a terminal is 80 columns wide, and rich would
    # hard-wrap a longer line (``… ETA 710`` / ``s``) in a log file
    say = (lambda s: console.print(s, soft_wrap=True, markup=False, highlight=False)) if console is not None else (lambda s: None)  # fmt: skip
    bar_ctx: Any = contextlib.nullcontext()
    task = None
    # off a terminal (a pipe, a file, a batch job) a bar draws nothing until the end: plain lines
    plain = _PlainProgress(say, description, len(chunks), summary) if progress and console is not None and not console.is_terminal else None  # fmt: skip
    if plain is not None:
        plain.start(len(todo))
    elif progress and console is not None:
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        bar_ctx = Progress(
            TextColumn(f"[bold]{description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
            TextColumn("ETA"), TimeRemainingColumn(), console=console, transient=False,
        )  # fmt: skip
    with bar_ctx as bar, _thread_env():
        if bar is not None:
            task = bar.add_task(description, total=len(chunks), completed=summary.skipped)

        def tick() -> None:
            if bar is not None:
                bar.advance(task)
            elif plain is not None:
                plain.tick()

        if todo:
            if executor == "local":
                _local(todo, out, workers, summary, tick, pool)
            elif executor == "dask":
                _dask(todo, out, workers, scheduler, summary, tick, say)
            elif executor == "inline":  # in this process (debugging, profiling)
                for c in todo:
                    summary.add(execute_chunk(c.to_json(), out))
                    tick()
            else:
                raise ValueError(f"unknown executor {executor!r}; expected 'local', 'dask' or 'inline'")
    summary.wall_s = time.perf_counter() - t0
    if summary.failures:
        store.write_text_atomic(
            Path(out) / "_failed" / f"failed-{os.getpid()}-{int(time.time())}.json",
            json.dumps(summary.failures, indent=2),
        )
    return summary


def run_sweep(
    catalog: Any,
    out: str | Path,
    *,
    engines: list[str] | None = None,
    profile: str | None = None,
    executor: str = "local",
    workers: int | None = None,
    scheduler: str | None = None,
    shard: str | None = None,
    chunk_size: int | None = None,
    progress: bool = True,
    console: Any = None,
) -> SweepSummary:
    """Build the catalog's chunks, take the shard, run them into ``out``."""
    from pbr_xval.catalog.spec import Catalog, load_catalog

    if not isinstance(catalog, Catalog):
        catalog = load_catalog(catalog)
    chunks = shard_chunks(
        build_chunks(catalog, engines=engines, profile=profile, chunk_size=chunk_size), shard
    )
    return run_chunks(
        chunks, out, executor=executor, workers=workers, scheduler=scheduler, progress=progress, console=console,
        description=f"{catalog.name}" + (f" shard {shard}" if shard else ""),
    )  # fmt: skip


def format_summary(s: SweepSummary) -> str:
    d = s.to_dict()
    lines = [
        f"chunks: {d['chunks_done']} done, {d['chunks_skipped']} skipped, {d['chunks_failed']} failed (of {d['chunks_total']})",
        f"simulations: {d['simulations']} in {d['wall_s']:.1f} s wall = {d['sims_per_s']:.2f} sims/s",
        f"core-seconds used: {d['core_s']:.1f} (store writes {d['write_s']:.2f} s)",
    ]
    if s.dashboard:
        lines.append(f"dashboard: {s.dashboard}")
    for f in s.failures:
        lines.append(f"FAILED chunk {f['chunk'][:12]} rock={f['rock']} engine={f['engine']}: {f['reason']}")
    return "\n".join(lines)
