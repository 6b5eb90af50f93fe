"""Run simulations in separate worker processes, so a crash or hang is a result, not a dead study.

Physics engines are C/C++ extensions: a segfault, an ``abort()`` in an assertion or an
endless solver loop would take the whole study down if run in-process. Here every job runs
in its own process started with the ``spawn`` method (the engines are not fork-safe), with
``OMP_NUM_THREADS=1``; the result comes back through a pipe, and the parent classifies:

* ``ok`` — the simulation ran and returned a trajectory with status ``ok``;
* ``failed`` — the engine returned a failed trajectory, or raised an exception;
* ``not_applicable`` — the engine cannot represent the scene (:class:`~pbr_xval.engine.NotApplicable`);
* ``unavailable`` — the engine is not installed (:class:`~pbr_xval.engine.EngineNotAvailable`);
* ``crash`` — the worker process died (signal or non-zero exit) before answering;
* ``timeout`` — no answer within ``timeout`` seconds; the worker is killed.

The scenario travels as a JSON dict (``scenario.model_dump(mode="json")``) plus a path whose
directory resolves relative file references (:func:`scenario_payload`). Engines are given
by registered name, by ``"package.module:Class"`` or by ``"/path/to/file.py:Class"`` (the
last two let tests point at an engine defined outside the registry, e.g. a crashing one).

Two entry points: :func:`run_isolated` (one simulation, blocking) and :func:`run_many`
(many tasks, at most ``max_workers`` processes at a time, results yielded as they complete;
one crashed process never affects the others). :class:`CallTask` runs any importable
function in a worker (used for whole threshold searches).
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.util
import math
import os
import signal as _signal
import sys
import tempfile
import threading
import time
import traceback
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pbr_xval.status import RunStatus

if TYPE_CHECKING:
    from pbr_xval.engine import Engine, Trajectory
    from pbr_xval.scenario import Scenario
    from pbr_xval.scene import Scene

__all__ = [
    "CallTask",
    "IsolatedResult",
    "SimTask",
    "call_isolated",
    "engine_label",
    "resolve_engine",
    "run_isolated",
    "run_many",
    "scenario_payload",
    "trajectory_summary",
]

#: the outcomes a worker reports (members of :class:`pbr_xval.status.RunStatus`)
STATUSES = (
    RunStatus.OK,
    RunStatus.FAILED,
    RunStatus.NOT_APPLICABLE,
    RunStatus.UNAVAILABLE,
    RunStatus.CRASH,
    RunStatus.TIMEOUT,
)
_ENV_LOCK = threading.Lock()
_STDERR_TAIL = 4000


# --------------------------------------------------------------------- engines
def resolve_engine(spec: str | type | Engine) -> Engine:
    """An engine instance from a registered name, ``"module:Class"``, ``"file.py:Class"``,
    a class or an instance."""
    from pbr_xval.engine import EngineNotAvailable, get_engine

    if not isinstance(spec, str) or ":" not in spec:
        return get_engine(spec)
    module, _, attr = spec.rpartition(":")
    try:
        if module.endswith(".py"):
            path = Path(module)
            mod_name = "_pbr_xval_engine_" + path.stem
            mod = sys.modules.get(mod_name)
            if mod is None:
                s = importlib.util.spec_from_file_location(mod_name, path)
                if s is None or s.loader is None:
                    raise ImportError(f"cannot load {path}")
                mod = importlib.util.module_from_spec(s)
                sys.modules[mod_name] = mod
                s.loader.exec_module(mod)
        else:
            mod = importlib.import_module(module)
        cls = getattr(mod, attr)
    except (ImportError, AttributeError, OSError) as exc:
        raise EngineNotAvailable(f"engine {spec!r} cannot be loaded: {exc}") from exc
    return get_engine(cls)


def engine_label(spec: str | type | Engine) -> str:
    """Display name of an engine spec (the class's ``name`` for ``module:Class`` specs)."""
    if isinstance(spec, str) and ":" not in spec:
        return spec
    try:
        return str(getattr(resolve_engine(spec), "name", "") or spec)
    except Exception:
        return str(spec)


# ------------------------------------------------------------------- scenarios
def scenario_payload(scn: Scenario) -> tuple[dict[str, Any], str]:
    """(JSON dict, source path) that :func:`pbr_xval.scenario.scenario_from_dict` rebuilds from.

    The source path's directory is where the scenario's relative paths resolve.
    """
    src = getattr(scn, "_source", None)
    base = Path(getattr(scn, "_base_dir", Path("."))).resolve()
    source = str(base / (Path(src).name if src is not None else f"{scn.name}.toml"))
    return scn.model_dump(mode="json"), source


def _scenario_from_payload(data: Mapping[str, Any], source: str | None) -> Scenario:
    from pbr_xval.scenario import scenario_from_dict

    return scenario_from_dict(dict(data), source=Path(source) if source else None)


# --------------------------------------------------------------------- summary
def _finite(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v


def trajectory_summary(traj: Trajectory, scene: Scene | None = None) -> dict[str, Any]:
    """Small JSON-able figures of a trajectory: outcome, peaks, penetration, energy, drift.

    Keys: ``toppled``, ``toppled_at_s``, ``peak_abs_theta_rad``, ``peak_tilt_rad``,
    ``final_tilt_rad``, ``max_com_disp_m`` (horizontal, from the start), ``final_com_disp_m``,
    ``max_penetration_m``, ``energy_max_rel_change``, ``energy_change_J``, ``n_impacts``,
    ``samples``, ``finite`` (all samples finite), ``nan_or_explosion``, ``alpha_rad``,
    ``min_dimension_m``, ``wall_time_s``.
    """
    import numpy as np

    out: dict[str, Any] = {
        "status": traj.status,
        "message": traj.message,
        "toppled": bool(traj.toppled),
        "toppled_at_s": traj.toppled_at,
        "samples": int(traj.t.size),
        "wall_time_s": float(traj.wall_time),
    }
    finite = True
    if traj.t.size:
        arrays = (traj.t, traj.com, traj.quat, traj.omega)
        finite = all(bool(np.all(np.isfinite(a))) for a in arrays)
        with np.errstate(all="ignore"):
            theta = traj.rocking_angle()
            tilt = traj.tilt()
            disp = np.hypot(traj.com[:, 0] - traj.com[0, 0], traj.com[:, 1] - traj.com[0, 1])
        out.update(
            peak_abs_theta_rad=float(np.nanmax(np.abs(theta))),
            peak_tilt_rad=float(np.nanmax(tilt)),
            final_tilt_rad=float(tilt[-1]),
            max_com_disp_m=float(np.nanmax(disp)),
            final_com_disp_m=float(disp[-1]),
        )
    else:
        out.update(
            peak_abs_theta_rad=None,
            peak_tilt_rad=None,
            final_tilt_rad=None,
            max_com_disp_m=None,
            final_com_disp_m=None,
        )
    d = traj.diagnostics or {}
    out["finite"] = finite
    out["nan_or_explosion"] = bool(d.get("nan_or_explosion", False)) or not finite
    out["max_penetration_m"] = _finite(d.get("max_penetration_m"))
    out["energy_max_rel_change"] = _finite(d.get("energy_max_rel_change"))
    e0, e1 = _finite(d.get("energy_start_J")), _finite(d.get("energy_end_J"))
    out["energy_change_J"] = (e1 - e0) if (e0 is not None and e1 is not None) else None
    # the shared definition (pbr_xval.diagnostics) for every engine; events only as a fallback
    out["n_impacts"] = int(d.get("impacts", len(traj.impacts())))
    if scene is not None:
        try:
            out["alpha_rad"] = float(min(scene.alpha))
            ext = scene.rock.mesh.extents
            out["min_dimension_m"] = float(min(ext))
            out["mass_kg"] = float(scene.rock.mass)
        except Exception:  # pragma: no cover - geometry facts are best-effort
            pass
    return out


# ---------------------------------------------------------------- child side
def simulate_batch(
    runs: Sequence[Mapping[str, Any]], engine: str, *, stop_on_error: bool = False
) -> list[dict[str, Any]]:
    """Run simulations in this process; one summary dict per run (never raises per run).

    Each run is ``{"scenario": data, "source": path, "settings": dict | None}``. Every
    summary carries ``status`` (ok / failed / not_applicable / unavailable), ``message``,
    ``settings``, ``versions``, ``diagnostics`` and the :func:`trajectory_summary` figures.
    """
    from pbr_xval.engine import EngineNotAvailable, NotApplicable
    from pbr_xval.runner import run_scene
    from pbr_xval.scene import compile_scene

    out: list[dict[str, Any]] = []
    try:
        eng = resolve_engine(engine)
    except EngineNotAvailable as exc:
        return [{"status": RunStatus.UNAVAILABLE, "message": str(exc)} for _ in runs]
    for run in runs:
        t0 = time.perf_counter()
        try:
            scn = _scenario_from_payload(run["scenario"], run.get("source"))
            scene = compile_scene(scn)
            traj = run_scene(scene, eng, run.get("settings") or {})
            res = trajectory_summary(traj, scene)
            from pbr_xval.jsonio import jsonable as _jsonable

            res.update(
                diagnostics=_jsonable(dict(traj.diagnostics)),
                settings=_jsonable(dict(traj.settings)),
                versions=dict(traj.versions),
                scenario_hash=traj.scenario_hash,
            )
            if traj.status != RunStatus.OK:
                res["status"] = RunStatus.FAILED
        except NotApplicable as exc:
            res = {"status": RunStatus.NOT_APPLICABLE, "message": str(exc)}
        except EngineNotAvailable as exc:
            res = {"status": RunStatus.UNAVAILABLE, "message": str(exc)}
        except Exception as exc:
            res = {
                "status": RunStatus.FAILED,
                "message": f"{type(exc).__name__}: {exc}",
                "traceback": traceback.format_exc(limit=8),
            }
        res["wall_s"] = time.perf_counter() - t0
        out.append(res)
        if stop_on_error and res["status"] != "ok":
            break
    return out


def _child_main(
    conn: Any,
    target: str,
    kwargs: dict[str, Any],
    extra_sys_path: Sequence[str],
    stderr_path: str | None,
    parent_pid: int | None = None,
) -> None:
    from pbr_xval.lifeline import die_with_parent

    die_with_parent(parent_pid)  # no orphan when the parent is killed
    os.environ["OMP_NUM_THREADS"] = "1"
    if stderr_path:
        with contextlib.suppress(OSError):
            fd = os.open(stderr_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
            os.dup2(fd, 2)
            os.close(fd)
    import faulthandler

    faulthandler.enable()
    for p in reversed(list(extra_sys_path)):
        if p not in sys.path:
            sys.path.insert(0, p)
    try:
        module, _, attr = target.partition(":")
        func = getattr(importlib.import_module(module), attr)
        value = func(**kwargs)
        msg: tuple[str, Any, str] = ("ok", value, "")
    except BaseException as exc:
        msg = ("error", None, f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=10)}")
    try:
        conn.send(msg)
    except Exception as exc:  # unpicklable value
        conn.send(("error", None, f"result could not be sent: {exc}"))
    conn.close()


# ---------------------------------------------------------------- parent side
@dataclass
class IsolatedResult:
    """The classified outcome of one isolated job.

    Attributes
    ----------
    status : ``ok``, ``failed``, ``not_applicable``, ``unavailable``, ``crash`` or ``timeout``.
    engine : the engine spec (simulations) or the call target.
    summary : :func:`trajectory_summary` figures of the (last) simulation; empty otherwise.
    diagnostics : the trajectory's diagnostics.
    message : why it is not ``ok`` (exception text, failed-trajectory message, signal, stderr tail).
    exitcode : the worker's exit code (negative: killed by that signal); ``signal`` its name.
    wall_s : wall-clock time of the job, including process start-up.
    value : the raw return value (a list of summaries for batches, anything for calls).
    settings, versions : of the (last) simulation.
    tag : the caller's tag, passed through.
    """

    status: RunStatus
    engine: str = ""
    summary: dict[str, Any] = field(default_factory=dict)
    diagnostics: dict[str, Any] = field(default_factory=dict)
    message: str = ""
    exitcode: int | None = None
    signal: str | None = None
    wall_s: float = 0.0
    value: Any = None
    settings: dict[str, Any] = field(default_factory=dict)
    versions: dict[str, str] = field(default_factory=dict)
    tag: Any = None

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def runs(self) -> list[dict[str, Any]]:
        """Per-simulation summaries of a batch (empty after a crash or timeout)."""
        return list(self.value) if isinstance(self.value, list) else []


@dataclass
class CallTask:
    """Call ``target`` (``"module:function"``) with ``kwargs`` in a worker; JSON/pickle-able in and out."""

    target: str
    kwargs: dict[str, Any] = field(default_factory=dict)
    tag: Any = None
    timeout: float | None = None
    extra_sys_path: tuple[str, ...] = ()
    label: str = ""


@dataclass
class SimTask:
    """One or more simulations of one engine in one worker.

    ``runs``: list of ``{"scenario": data, "source": path, "settings": dict}``; use
    :meth:`single` for one simulation.
    """

    engine: str
    runs: list[dict[str, Any]]
    tag: Any = None
    timeout: float | None = None
    extra_sys_path: tuple[str, ...] = ()

    @classmethod
    def single(
        cls,
        scenario_data: dict[str, Any],
        engine: str,
        settings: Mapping[str, Any] | None = None,
        *,
        source: str | None = None,
        **kw: Any,
    ) -> SimTask:
        return cls(
            engine, [{"scenario": scenario_data, "source": source, "settings": dict(settings or {})}], **kw
        )

    def to_call(self) -> CallTask:
        return CallTask(
            "pbr_xval.study.workers:simulate_batch",
            {"runs": self.runs, "engine": self.engine},
            self.tag,
            self.timeout,
            self.extra_sys_path,
            label=str(self.engine),
        )


class _Job:
    def __init__(self, task: CallTask | SimTask, default_timeout: float | None) -> None:
        import multiprocessing as mp

        self.task = task
        call = task.to_call() if isinstance(task, SimTask) else task
        self.call = call
        self.timeout = call.timeout if call.timeout is not None else default_timeout
        ctx = mp.get_context("spawn")
        self.conn, child = ctx.Pipe(duplex=False)
        fd, self.stderr_path = tempfile.mkstemp(prefix="pbr_xval_worker_", suffix=".stderr")
        os.close(fd)
        self.proc = ctx.Process(
            target=_child_main,
            args=(child, call.target, call.kwargs, tuple(call.extra_sys_path), self.stderr_path, os.getpid()),
            daemon=True,
        )
        self.t0 = time.perf_counter()
        with _ENV_LOCK:  # the child inherits the environment at spawn time
            old = os.environ.get("OMP_NUM_THREADS")
            os.environ["OMP_NUM_THREADS"] = "1"
            try:
                self.proc.start()
            finally:
                if old is None:
                    os.environ.pop("OMP_NUM_THREADS", None)
                else:
                    os.environ["OMP_NUM_THREADS"] = old
        child.close()

    @property
    def deadline(self) -> float:
        return math.inf if self.timeout is None else self.t0 + self.timeout

    def _stderr_tail(self) -> str:
        try:
            with open(self.stderr_path, "rb") as f:
                f.seek(0, os.SEEK_END)
                n = f.tell()
                f.seek(max(0, n - _STDERR_TAIL))
                return f.read().decode(errors="replace").strip()
        except OSError:
            return ""

    def finish(self, timed_out: bool = False) -> IsolatedResult:
        msg: tuple[str, Any, str] | None = None
        if not timed_out and self.conn.poll():
            try:
                msg = self.conn.recv()
            except (EOFError, OSError):
                msg = None
        if timed_out or msg is None:
            self.proc.join(0.5 if not timed_out else 0)
        else:
            self.proc.join(10.0)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join(5.0)
        wall = time.perf_counter() - self.t0
        code = self.proc.exitcode
        sig = None
        if code is not None and code < 0:
            try:
                sig = _signal.Signals(-code).name
            except ValueError:
                sig = f"signal {-code}"
        tail = self._stderr_tail()
        with contextlib.suppress(OSError):
            os.unlink(self.stderr_path)
        self.conn.close()
        label = self.task.engine if isinstance(self.task, SimTask) else self.call.target
        res = IsolatedResult(
            status=RunStatus.OK, engine=str(label), exitcode=code, signal=sig, wall_s=wall, tag=self.task.tag
        )
        if timed_out:
            res.status = RunStatus.TIMEOUT
            res.message = f"no answer within {self.timeout:g} s; worker killed"
        elif msg is None:
            res.status = RunStatus.CRASH
            how = f"killed by {sig}" if sig else f"exited with code {code}"
            res.message = f"worker process {how} before answering" + (
                f"; stderr: {tail[-800:]}" if tail else ""
            )
            if "finished its bootstrapping phase" in tail:
                res.message = (
                    "worker could not start: the calling script starts workers at import time; "
                    "wrap its top level in `if __name__ == '__main__':` (spawn re-imports the main module)"
                )
        elif msg[0] == "error":
            res.status = RunStatus.FAILED
            res.message = msg[2]
        else:
            res.value = msg[1]
            if isinstance(self.task, SimTask):
                _fill_from_runs(res)
        return res


def _fill_from_runs(res: IsolatedResult) -> None:
    runs = res.runs
    if not runs:
        res.status = RunStatus.FAILED
        res.message = "no simulation result"
        return
    bad = [r for r in runs if r.get("status") != "ok"]
    last = bad[0] if bad else runs[-1]
    res.status = RunStatus(last.get("status", RunStatus.FAILED)) if bad else RunStatus.OK
    res.message = str(last.get("message", ""))
    res.summary = {
        k: v for k, v in last.items() if k not in ("diagnostics", "settings", "versions", "traceback")
    }
    res.diagnostics = dict(last.get("diagnostics") or {})
    res.settings = dict(last.get("settings") or {})
    res.versions = dict(last.get("versions") or {})


def run_many(
    tasks: Iterable[CallTask | SimTask], max_workers: int = 1, timeout: float | None = None
) -> Iterator[IsolatedResult]:
    """Run tasks in worker processes (one process per task, at most ``max_workers`` at once).

    Yields an :class:`IsolatedResult` per task as it completes (``tag`` identifies the task).
    ``timeout`` is the default per-task limit (a task's own ``timeout`` wins). A crash or a
    timeout of one task never affects the others. Closing the generator kills running workers.
    """
    from multiprocessing.connection import wait

    pending = list(tasks)
    pending.reverse()
    running: list[_Job] = []
    max_workers = max(1, int(max_workers))
    try:
        while pending or running:
            while pending and len(running) < max_workers:
                running.append(_Job(pending.pop(), timeout))
            now = time.perf_counter()
            next_deadline = min(j.deadline for j in running)
            wait_for = None if math.isinf(next_deadline) else max(0.0, next_deadline - now)
            handles: list[Any] = []
            for j in running:
                handles += [j.conn, j.proc.sentinel]
            ready = set(wait(handles, timeout=wait_for))
            now = time.perf_counter()
            still: list[_Job] = []
            done: list[IsolatedResult] = []
            for j in running:
                if j.conn in ready or j.proc.sentinel in ready:
                    done.append(j.finish())
                elif now >= j.deadline:
                    done.append(j.finish(timed_out=True))
                else:
                    still.append(j)
            running = still
            yield from done
    finally:
        for j in running:
            if j.proc.is_alive():
                j.proc.kill()
            j.proc.join(5.0)
            with contextlib.suppress(OSError):
                os.unlink(j.stderr_path)


def call_isolated(
    target: str,
    kwargs: Mapping[str, Any] | None = None,
    *,
    timeout: float | None = None,
    extra_sys_path: Sequence[str] = (),
) -> IsolatedResult:
    """Call ``"module:function"`` with ``kwargs`` in a worker process; the return value is in ``.value``."""
    task = CallTask(target, dict(kwargs or {}), timeout=timeout, extra_sys_path=tuple(extra_sys_path))
    return next(iter(run_many([task], 1)))


def run_isolated(
    scenario_data: Mapping[str, Any] | Scenario,
    engine: str,
    settings: Mapping[str, Any] | None = None,
    *,
    timeout: float,
    source: str | None = None,
    extra_sys_path: Sequence[str] = (),
) -> IsolatedResult:
    """Simulate one scenario on one engine in a worker process and classify the outcome.

    ``scenario_data`` is ``scenario.model_dump(mode="json")`` (or a Scenario, converted with
    :func:`scenario_payload`); ``source`` is a path whose directory resolves relative file
    references. ``engine`` is a registered name, ``"module:Class"`` or ``"file.py:Class"``.
    """
    if not isinstance(scenario_data, Mapping):
        scenario_data, src = scenario_payload(scenario_data)
        source = source or src
    task = SimTask.single(
        dict(scenario_data),
        engine,
        settings,
        source=source,
        timeout=timeout,
        extra_sys_path=tuple(extra_sys_path),
    )
    return next(iter(run_many([task], 1)))
