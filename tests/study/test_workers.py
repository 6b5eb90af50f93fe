from __future__ import annotations

import time
from pathlib import Path

from pbr_xval.conformance import housner_scenario
from pbr_xval.study.workers import (
    CallTask,
    SimTask,
    call_isolated,
    engine_label,
    run_isolated,
    run_many,
    scenario_payload,
)

CRASHY = str(Path(__file__).with_name("_crashy_engine.py"))


def _short():
    return housner_scenario(duration=0.3, settle_time=0.0)


def test_ok_housner_summary():
    data, src = scenario_payload(_short())
    res = run_isolated(data, "housner", {}, timeout=60, source=src)
    assert res.status == "ok", res.message
    assert res.summary["toppled"] is False
    assert res.summary["peak_abs_theta_rad"] > 0
    assert res.settings["profile"] == "faithful"
    assert res.exitcode == 0
    assert res.wall_s > 0


def test_many_contains_crash_hang_and_errors():
    data, src = scenario_payload(_short())
    tasks = [
        SimTask.single(data, f"{CRASHY}:AbortEngine", source=src, tag="abort"),
        SimTask.single(data, f"{CRASHY}:HangEngine", source=src, tag="hang", timeout=3.0),
        SimTask.single(data, f"{CRASHY}:SegfaultEngine", source=src, tag="segv"),
        # a batch: the first failing run is reported, every run's summary is kept
        SimTask(f"{CRASHY}:RaiseEngine", [{"scenario": data, "source": src}], tag="raise"),
        SimTask(f"{CRASHY}:NaNEngine", [{"scenario": data, "source": src}] * 2, tag="nan"),
        SimTask.single(data, f"{CRASHY}:StillEngine", source=src, tag="still"),
    ]
    t0 = time.perf_counter()
    out = {r.tag: r for r in run_many(tasks, max_workers=2, timeout=60)}
    assert time.perf_counter() - t0 < 45
    assert out["abort"].status == "crash" and out["abort"].signal == "SIGABRT"
    assert out["hang"].status == "timeout"
    assert out["segv"].status == "crash" and out["segv"].signal == "SIGSEGV"
    assert out["segv"].exitcode is not None and out["segv"].exitcode < 0
    assert "SIGSEGV" in out["segv"].message
    assert out["raise"].status == "failed" and "exploded politely" in out["raise"].message
    assert out["nan"].status == "failed" and "NaN" in out["nan"].message and len(out["nan"].runs) == 2
    assert out["still"].status == "ok" and out["still"].summary["toppled"] is False


def test_call_isolated_and_label():
    res = call_isolated("math:sqrt", {}, timeout=30)
    assert res.status == "failed" and "TypeError" in res.message
    res = next(
        iter(
            run_many(
                [
                    CallTask(
                        "pbr_xval.study.workers:simulate_batch", {"runs": [{}], "engine": "no_such_engine"}
                    )
                ]
            )
        )
    )
    assert res.ok and res.value[0]["status"] == "unavailable"
    assert engine_label(f"{CRASHY}:SegfaultEngine") == "segfault"
