"""The stepping core (pbr_xval.stepping) driven by a fake engine with a prescribed motion.

The fake stepper rotates the Housner block about its support edge by a prescribed angle θ(t)
(no physics), so every event time is known in advance. The core records blocks of steps with
a vectorised screen; the independent reference is the per-step recorder: the same states fed
one by one to :meth:`Recorder.record` (the adapters' loop before the core existed). Both must
give the same samples and events, bit for bit — in particular events that happen *between*
two output samples (uplift, a brief excursion past the critical tilt, the decision time, a NaN).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pbr_xval.conformance import housner_scenario
from pbr_xval.scene import compile_scene
from pbr_xval.stepping import (
    Recorder,
    StepBlock,
    StepperBase,
    n_steps,
    rotation_about,
    run_steps,
    sample_steps,
)

DT = 1e-3


def _scene(output_dt: float = 1e-2, duration: float = 1.0, **kw):
    exc = {"type": "half_sine", "amplitude": 5.0, "frequency": 1.0, "phase": "housner_uplift"}
    return compile_scene(housner_scenario(duration=duration, output_dt=output_dt, excitation=exc, **kw))


class FakeStepper(StepperBase):
    """Prescribed rocking θ(t) (rad) about the +d support edge of the scene's rock."""

    def __init__(self, scene, theta, raise_at: int | None = None) -> None:
        self.scene, self.theta, self.raise_at = scene, theta, raise_at
        com = np.asarray(scene.rock.com, dtype=float)
        self.com0 = com
        v = scene.rock.mesh.vertices
        self.pivot = np.array([com[0] + (v[:, 0].max() - com[0]), com[1], v[:, 2].min()])
        self.e = scene.rocking_axis

    def set_initial(self, com, rot, vel, omega) -> None:  # the fake starts at rest
        raise AssertionError("not tilted")

    def settle(self, n: int) -> None:
        self.settled = n

    def state(self):
        return self.com0.copy(), np.eye(3), 0.0

    def begin(self, n: int) -> None:
        self.n = n

    def pose(self, k: int):
        th = self.theta((k + 1) * DT)
        r = rotation_about(self.e, th) if math.isfinite(th) else np.full((3, 3), np.nan)
        com = self.pivot + r @ (self.com0 - self.pivot)
        w = (self.theta((k + 1.5) * DT) - self.theta((k + 0.5) * DT)) / DT * self.e
        return com, r, w

    def advance(self, k0: int, k1: int, block: StepBlock) -> None:
        i = 0
        for k in range(k0, k1):
            if self.raise_at is not None and k == self.raise_at:
                raise RuntimeError("engine blew up")
            if block.keep is not None and not block.keep[k]:
                continue  # a samples-only stepper reads nothing between samples
            com, r, w = self.pose(k)
            block.com[i], block.rot[i], block.omega[i] = com, r.ravel(), w
            block.ncon[i], block.pen[i] = 2 + k % 3, 1e-6 * (k % 7)
            i = block.n = i + 1


def per_step(scene, stepper: FakeStepper) -> Recorder:
    """The reference: every state through Recorder.record, as the adapters did before the core."""
    rec = Recorder(scene, DT)
    rec.start(stepper.com0, np.eye(3))
    n = n_steps(float(scene.duration), DT)
    for k in range(n):
        if stepper.raise_at is not None and k == stepper.raise_at:
            break
        com, r, w = stepper.pose(k)
        if rec.record(
            (k + 1) * DT, com, r, w, n_contacts=2 + k % 3, penetration=1e-6 * (k % 7), force=k == n - 1
        ):
            break
    return rec


def _counts(r: Recorder) -> tuple[int, int, int, int]:
    return r._nc_min, r._nc_max, r._nc_sum, r._nc_cnt


def _same(a: Recorder, b: Recorder) -> None:
    assert a.t == b.t
    assert np.array_equal(a.com, b.com) and np.array_equal(a.rot, b.rot) and np.array_equal(a.omega, b.omega)
    assert [e.to_dict() for e in a.events] == [e.to_dict() for e in b.events]
    assert _counts(a) == _counts(b) and a.max_penetration == b.max_penetration
    assert (a._past, a._outward, a._prev_cos, a._toppled, a.undecided) == (
        b._past,
        b._outward,
        b._prev_cos,
        b._toppled,
        b.undecided,
    )


ALPHA = math.atan(0.2 / 0.6)


@pytest.mark.parametrize(
    "name, theta",
    [
        # rocks below α: uplift at a step between two samples (output every 10 steps)
        ("rocking", lambda t: 0.5 * ALPHA * math.sin(2 * math.pi * t) ** 2),
        # past α for 5 steps (between the samples at 0.20 and 0.21 s) while the pulse is on
        # (it ends at 0.40 s), then back: stands
        ("brief excursion", lambda t: ALPHA * max(0.0, 1.002 - 0.002 * ((t - 0.2055) / 0.003) ** 2)),
        # tilts to the ground: "down" decided at a step between samples, crossing time per step
        ("topples", lambda t: min(math.pi / 2 + 0.1, 3.0 * t * t)),
        # the state turns NaN at a step between samples: failed at that step
        ("nan", lambda t: math.nan if t > 0.5034 else 0.1 * t),
    ],
)
@pytest.mark.parametrize("block", [1, 7, 64])
def test_block_recording_equals_per_step(name, theta, block) -> None:
    scene = _scene()
    rec, _ = run_steps(FakeStepper(scene, theta), scene, DT, block=block)
    _same(rec, per_step(scene, FakeStepper(scene, theta)))
    kinds = [e.kind for e in rec.events]
    if name != "nan":
        assert "uplift" in kinds
        # the uplift step lies between two samples: its time is a step time, not a sample time
        t_up = next(e.t for e in rec.events if e.kind == "uplift")
        assert t_up not in rec.t
    if name == "brief excursion":  # past α only between samples; still decided per step: stands
        th = np.array([theta(t) for t in rec.t])
        assert th.max() < ALPHA * 1.0001 and "toppled" not in kinds
    if name == "topples":
        ev = next(e for e in rec.events if e.kind == "toppled")
        # last outward crossing of α: the first step with 3 t² > α (the fake crosses once)
        k_cross = math.ceil(math.sqrt(ALPHA / 3.0) / DT - 1e-9)
        assert ev.t == pytest.approx(k_cross * DT, abs=1.5 * DT)
        assert ev.t not in rec.t[:-1]
    if name == "nan":
        ev = next(e for e in rec.events if e.kind == "failed")
        # ω at the step ending at 0.503 s uses θ(0.5035 s), the first NaN (the pose at 0.504 s)
        assert ev.t == pytest.approx(0.503, abs=1e-12) and rec.failed


class SampledFakeStepper(FakeStepper):
    """The fake, reading the state at the output samples only (as the engine adapters do)."""

    samples_only = True


@pytest.mark.parametrize(
    "name, theta",
    [
        ("rocking", lambda t: 0.5 * ALPHA * math.sin(2 * math.pi * t) ** 2),
        ("brief excursion", lambda t: ALPHA * max(0.0, 1.002 - 0.002 * ((t - 0.2055) / 0.003) ** 2)),
        ("topples", lambda t: min(math.pi / 2 + 0.1, 3.0 * t * t)),
        ("nan", lambda t: math.nan if t > 0.5034 else 0.1 * t),
    ],
)
@pytest.mark.parametrize("block", [1, 7, 64])
def test_sample_rate_recording(name, theta, block) -> None:
    """Reading the state at the output samples only: the same samples, decisions within one sample.

    The reference is the per-step recorder fed every step. With the physical criterion a
    samples-only adapter gives exactly its samples (same times, same states) up to the decision,
    the same verdict (toppled, stands, failed), and each event dated at the first sample at or
    after the reference's step (never earlier, at most one output interval later).
    """
    scene = _scene()
    out = float(scene.output_dt)
    rec, diag = run_steps(SampledFakeStepper(scene, theta), scene, DT, block=block)
    ref = per_step(scene, FakeStepper(scene, theta))
    assert diag["recorded_steps"] == "output samples"
    n = len(rec.t)
    assert rec.t[: n - 1] == ref.t[: n - 1]  # the last row may be the stopping sample
    assert np.array_equal(rec.com[: n - 1], ref.com[: n - 1]) and np.array_equal(
        rec.rot[: n - 1], ref.rot[: n - 1]
    )
    kinds = lambda r: sorted({e.kind for e in r.events})  # noqa: E731
    assert kinds(rec) == kinds(ref)
    for e in rec.events:
        e_ref = next(x for x in ref.events if x.kind == e.kind)
        assert e_ref.t - 1e-12 <= e.t <= e_ref.t + out + 1e-12, e.kind
        assert abs(e.t / out - round(e.t / out)) < 1e-6 or e.t == rec.t[0]  # at a sample time
    if name == "brief excursion":
        assert "toppled" not in kinds(rec)


def test_sample_rate_recording_engine_exception_names_the_step_range() -> None:
    """Reading at the samples only, an engine error is placed between the last sample and the next."""
    scene = _scene()  # samples every 10 steps
    rec, diag = run_steps(
        SampledFakeStepper(scene, lambda t: 0.0, raise_at=333), scene, DT, block=4, name="fake"
    )
    assert (
        rec.failed.startswith("fake: engine error between steps 330 and 340") and "RuntimeError" in rec.failed
    )
    assert rec.t[-1] == pytest.approx(0.33) and diag["steps"] == 330  # the samples before it are kept


def test_sample_rate_recording_keeps_every_step_for_first_crossing_rules() -> None:
    """A first-crossing criterion needs every step: a samples-only adapter is then fed every step."""
    scene = _scene(toppling={"criterion": "critical_tilt"})
    theta = lambda t: ALPHA * max(0.0, 1.002 - 0.002 * ((t - 0.2055) / 0.003) ** 2)  # noqa: E731
    rec, diag = run_steps(SampledFakeStepper(scene, theta), scene, DT, block=64)
    assert "recorded_steps" not in diag
    _same(rec, per_step(scene, FakeStepper(scene, theta)))
    assert any(e.kind == "toppled" for e in rec.events)  # the crossing between samples is seen


def test_sample_steps_are_the_recorders_samples() -> None:
    for out, dt, dur in ((1e-2, 1e-3, 1.0), (1e-3, 1e-4, 0.3), (1e-3, 3e-4, 0.5), (7e-3, 1e-3, 0.2)):
        scene = _scene(output_dt=out, duration=dur)
        rec = Recorder(scene, dt)
        rec.start(scene.rock.com, np.eye(3))
        n = n_steps(dur, dt)
        rows = sample_steps(rec, n)
        kept = []
        for k in range(n):
            before = len(rec.t)
            rec.record((k + 1) * dt, scene.rock.com, np.eye(3), np.zeros(3), force=k == n - 1)
            if len(rec.t) > before:
                kept.append(k)
        assert rows == kept, (out, dt)
    scene = _scene(output_dt=1e-3)
    rec = Recorder(scene, 1e-3)
    rec.start(scene.rock.com, np.eye(3))
    assert sample_steps(rec, 100) is None  # output_dt = dt: every step is a sample


def test_engine_exception_is_a_failed_run_keeping_the_samples() -> None:
    scene = _scene()
    theta = lambda t: 0.2 * ALPHA * t  # noqa: E731
    rec, diag = run_steps(FakeStepper(scene, theta, raise_at=333), scene, DT, block=64, name="fake")
    assert rec.failed.startswith("fake: engine error after 333 steps") and "RuntimeError" in diag["exception"]
    ref = per_step(scene, FakeStepper(scene, theta, raise_at=333))
    assert rec.t == ref.t and rec.t[-1] == pytest.approx(0.33)  # nothing computed before is lost
    traj = rec.trajectory("fake", {}, {})
    assert traj.status == "failed" and len(traj.t) == len(ref.t)


def test_settling_and_step_count() -> None:
    scene = _scene(settle_time=0.25)
    st = FakeStepper(scene, lambda t: 0.0)
    rec, diag = run_steps(st, scene, DT)
    assert st.settled == 250 and diag["settle_steps"] == 250 and diag["steps"] == 1000
    assert rec.t[-1] == pytest.approx(1.0) and len(rec.t) == 101  # every 10 ms, the last step kept


@pytest.mark.parametrize("engine", ["mujoco", "pybullet", "dart"])
def test_adapters_record_every_step_state(engine: str) -> None:
    """An engine run sampled every 10 ms has the same samples as its 1 ms run at those times.

    The sampled states do not depend on the output rate (the engine steps the same way, whether
    or not the state is read); the verdict neither, with events dated to the output resolution.
    """
    pytest.importorskip({"mujoco": "mujoco", "pybullet": "pybullet", "dart": "dartpy"}[engine])
    from pbr_xval.runner import run_scene

    exc = {"type": "half_sine", "amplitude": 6.0, "frequency": 1.0, "phase": "housner_uplift"}
    fine = run_scene(compile_scene(housner_scenario(duration=2.0, excitation=exc)), engine)
    coarse = run_scene(compile_scene(housner_scenario(duration=2.0, excitation=exc, output_dt=1e-2)), engine)
    tf = fine.t.tolist()
    common = [t for t in coarse.t.tolist() if t <= tf[-1]]  # the coarse run may stop one sample later
    assert len(common) > 50 and all(t in tf for t in common)  # same step times
    for i, t in enumerate(common):
        assert np.array_equal(fine.com[tf.index(t)], coarse.com[i])
    # the adapters read the state at the output samples only: every event is seen, dated at the
    # first 10 ms sample at or after its 1 ms step
    assert [e.kind for e in fine.events] == [e.kind for e in coarse.events] and coarse.toppled
    for a, b in zip(fine.events, coarse.events, strict=True):
        assert a.t - 1e-12 <= b.t <= a.t + 1e-2 + 1e-12


def test_mujoco_model_cache_reused_across_excitations_and_safe_in_threads() -> None:
    """One MuJoCo compile per scene geometry + settings and thread; results as without the cache.

    The reference is a fresh compile for every run (the cache emptied before each): sweeps that
    reuse the model, also from two threads at once, must give the same trajectories bit for bit.
    """
    pytest.importorskip("mujoco")
    from concurrent.futures import ThreadPoolExecutor

    from pbr_xval.engines import _common
    from pbr_xval.runner import run_scene

    def scene(a: float):
        exc = {"type": "half_sine", "amplitude": a, "frequency": 1.0, "phase": "housner_uplift"}
        return compile_scene(housner_scenario(duration=1.5, excitation=exc))

    scenes = [scene(a) for a in (5.0, 5.5, 6.0)]
    fresh = []
    for sc in scenes:
        _common._MODELS.__dict__.pop("models", None)
        fresh.append(run_scene(sc, "mujoco").fingerprint())
    before = _common.MODEL_BUILDS.get("mujoco", 0)
    assert [run_scene(sc, "mujoco").fingerprint() for sc in scenes] == fresh
    assert _common.MODEL_BUILDS["mujoco"] == before  # same geometry and settings: no new compile
    with ThreadPoolExecutor(2) as ex:
        got = list(ex.map(lambda sc: run_scene(sc, "mujoco").fingerprint(), scenes * 3))
    assert got == fresh * 3
    assert _common.MODEL_BUILDS["mujoco"] <= before + 2  # at most one per thread


def test_short_blocks_near_toppling_bound_the_overshoot() -> None:
    """Once the rock reaches half its critical tilt the core takes an eighth of a block, so an
    engine stops at most block/8 steps after the toppling decision (not a whole block later)."""

    class Counting(FakeStepper):
        reached = 0

        def advance(self, k0, k1, block):
            super().advance(k0, k1, block)
            self.reached = max(self.reached, k1)

    scene = _scene(output_dt=1e-3)
    st = Counting(scene, lambda t: min(math.pi / 2 + 0.1, 3.0 * t * t))
    rec, diag = run_steps(st, scene, DT, block=256)
    assert any(e.kind == "toppled" for e in rec.events)
    assert 0 <= st.reached - diag["steps"] <= 256 // 8


@pytest.mark.parametrize("engine", ["mujoco", "pybullet", "dart", "reference"])
def test_stop_at_rest_ends_early_with_the_full_runs_outcome(engine: str) -> None:
    """``toppling.stop_at_rest`` (issue 23): a block rocked by a pulse below its threshold comes
    to rest after the pulse and the run stops there — same outcome, same peak tilt, much
    shorter; a block that topples is decided as before (the stop never applies)."""
    from pbr_xval.engine import EngineNotAvailable, get_engine
    from pbr_xval.runner import run_scene

    try:
        get_engine(engine)
    except (EngineNotAvailable, ImportError):
        pytest.skip(f"{engine} not installed")

    def run(a: float, on: bool):
        exc = {"type": "half_sine", "amplitude": a, "frequency": 1.0, "phase": "housner_uplift"}
        toppling = {"stop_at_rest": True} if on else {}
        return run_scene(
            compile_scene(housner_scenario(duration=6.0, excitation=exc, toppling=toppling)), engine
        )

    full, short = run(4.0, False), run(4.0, True)
    assert full.ok and short.ok
    assert not full.toppled and not short.toppled
    assert full.tilt().max() > 0.01  # it rocked
    assert "stopped_at_rest" not in full.diagnostics  # off: nothing new recorded, nothing changed
    assert short.diagnostics["stopped_at_rest"] is True
    t_rest = short.diagnostics["stopped_at_rest_s"]
    assert short.t[-1] == pytest.approx(t_rest) and t_rest < 2.5 < full.t[-1]
    assert short.tilt().max() == pytest.approx(full.tilt().max(), rel=1e-9)
    assert short.scene_info["toppling"]["stop_at_rest"] is True
    n = short.t.size - 1  # identical up to the stop (the stop only truncates)
    assert np.array_equal(short.t[:n], full.t[:n]) and np.array_equal(short.com[:n], full.com[:n])
    top_full, top_short = run(5.7, False), run(5.7, True)
    assert top_full.toppled and top_short.toppled
    assert top_short.toppled_at == top_full.toppled_at and top_short.fingerprint() == top_full.fingerprint()
    assert top_short.diagnostics["stopped_at_rest"] is False


def test_stop_at_rest_leaves_the_scenario_hash_when_unset() -> None:
    """A scenario that does not set ``stop_at_rest`` hashes as before the key existed."""
    off = housner_scenario()
    assert "stop_at_rest" not in off.normalised()["toppling"]
    assert housner_scenario(toppling={"stop_at_rest": False}).content_hash() == off.content_hash()
    assert housner_scenario(toppling={"stop_at_rest": True}).content_hash() != off.content_hash()
