"""Engine adapter speed on the Housner block: wall time per simulated second and harness overhead.

Prints, for each installed engine and time step:

* wall seconds per simulated second of the adapter (``run_scene``: model build, settling,
  drive, recording, toppling checks, diagnostics), sub-threshold run a = 5.0 m/s², 5 s after
  0.5 s of settling;
* the same for a *bare loop*: the engine's own step calls on the same model (the box block on
  a box pedestal with the faithful settings), setting the mid-step tilted gravity every step
  and reading the pose and angular velocity at the output rate (every step when dt = output_dt
  = 1 ms; every 10th step at dt = 0.1 ms), written directly against the engine API as in the
  engine notes — the same output the adapter produces, without its checks and diagnostics
  (the adapter also reads the contacts at every sample);
* their ratio (the harness overhead; goal ≤ 1.3×); the adapter runs after one warm-up run,
  so a compiled model cached by the adapter (MuJoCo) is reused as in a sweep;
* for MuJoCo, the gain of the native multi-step path ``mj_step(m, d, n)`` over a Python loop
  of single steps (usable where no per-step drive is needed: settling).

Usage: ``python benchmarks/engines.py [--repeat 3] [--engines pybullet,mujoco,dart]``
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from pbr_xval.conformance import housner_scenario
from pbr_xval.engine import EngineNotAvailable, get_engine
from pbr_xval.runner import run_scene
from pbr_xval.scene import compile_scene

B, H, D, MASS, G = 0.2, 0.6, 0.2, 460.8, 9.81
SETTLE, DURATION, AMP = 0.5, 5.0, 5.0
OUTPUT_DT = 1e-3  # s, the scene's output rate (the default)


def every(dt: float) -> int:
    """Steps per output sample."""
    return max(1, round(OUTPUT_DT / dt))


def drive(dt: float, n: int) -> np.ndarray:
    """Mid-step horizontal pedestal acceleration (n,) of the Housner half-sine, m/s²."""
    phi = math.asin(G * B / H / AMP)
    t = (np.arange(n) + 0.5) * dt
    return np.where(2 * np.pi * t + phi <= np.pi, AMP * np.sin(2 * np.pi * t + phi), 0.0)


def bare_pybullet(dt: float) -> float:
    import pybullet as p

    cid = p.connect(p.DIRECT)
    try:
        p.setPhysicsEngineParameter(
            fixedTimeStep=dt, numSubSteps=0, numSolverIterations=50, physicsClientId=cid
        )
        ped = p.createMultiBody(
            0,
            p.createCollisionShape(p.GEOM_BOX, halfExtents=[50, 50, 0.5], physicsClientId=cid),
            basePosition=[0, 0, -0.5],
            physicsClientId=cid,
        )
        blk = p.createMultiBody(
            MASS,
            p.createCollisionShape(p.GEOM_BOX, halfExtents=[B, D, H], physicsClientId=cid),
            basePosition=[0, 0, H],
            physicsClientId=cid,
        )
        for body, mu in ((ped, 1.0), (blk, 2.0)):
            p.changeDynamics(
                body,
                -1,
                lateralFriction=mu,
                restitution=0.0,
                linearDamping=0,
                angularDamping=0,
                physicsClientId=cid,
            )
        p.setGravity(0, 0, -G, physicsClientId=cid)
        n_set, n, e = round(SETTLE / dt), round(DURATION / dt), every(dt)
        a = drive(dt, n).tolist()
        t0 = time.perf_counter()
        for _ in range(n_set):
            p.stepSimulation(physicsClientId=cid)
        p.getBasePositionAndOrientation(blk, physicsClientId=cid)
        for k in range(n):
            p.setGravity(-a[k], 0, -G, physicsClientId=cid)
            p.stepSimulation(physicsClientId=cid)
            if (k + 1) % e == 0:
                p.getBasePositionAndOrientation(blk, physicsClientId=cid)
                p.getBaseVelocity(blk, physicsClientId=cid)
        return time.perf_counter() - t0
    finally:
        p.disconnect(cid)


def _mujoco_model(dt: float):
    import mujoco

    xml = f"""<mujoco><option timestep="{dt}" integrator="implicitfast" cone="elliptic"/>
      <default><geom friction="2 0 0" solref="{2 * dt} 1" solimp="0.999 0.9999 0.001 0.5 2"/></default>
      <worldbody><geom type="box" size="50 50 0.5" pos="0 0 -0.5"/>
        <body name="block" pos="0 0 {H}"><freejoint/><geom type="box" size="{B} {D} {H}" mass="{MASS}"/></body>
      </worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    return mujoco, m, mujoco.MjData(m)


def bare_mujoco(dt: float) -> float:
    mujoco, m, d = _mujoco_model(dt)
    n_set, n, e = round(SETTLE / dt), round(DURATION / dt), every(dt)
    a = drive(dt, n).tolist()
    mat = np.zeros(9)
    t0 = time.perf_counter()
    mujoco.mj_step(m, d, n_set)
    for k in range(n):
        m.opt.gravity[0] = -a[k]
        mujoco.mj_step(m, d)
        if (k + 1) % e == 0:
            mujoco.mju_quat2Mat(mat, d.qpos[3:7])
            d.qvel[:6].copy()
    return time.perf_counter() - t0


def mujoco_multistep_gain(dt: float) -> tuple[float, float]:
    """(python loop s, native nstep s) for the settling phase."""
    out = []
    for native in (False, True):
        mujoco, m, d = _mujoco_model(dt)
        n = round(SETTLE / dt)
        t0 = time.perf_counter()
        if native:
            mujoco.mj_step(m, d, n)
        else:
            for _ in range(n):
                mujoco.mj_step(m, d)
        out.append(time.perf_counter() - t0)
    return out[0], out[1]


def bare_dart(dt: float) -> float:
    import dartpy as dart

    dyn = dart.dynamics
    world = dart.simulation.World()
    world.setGravity([0, 0, -G])
    world.setTimeStep(dt)
    opts = world.getDeactivationOptions()
    opts.mEnabled = False
    world.setDeactivationOptions(opts)
    blk = dyn.Skeleton("block")
    fj, body = blk.createFreeJointAndBodyNodePair()
    box = dyn.BoxShape([2 * B, 2 * D, 2 * H])
    sn = body.createShapeNode(box)
    sn.createCollisionAspect()
    asp = sn.createDynamicsAspect()
    asp.setFrictionCoeff(2.0)
    asp.setRestitutionCoeff(0.0)
    body.setInertia(dyn.Inertia(MASS, [0, 0, 0], box.computeInertia(MASS)))
    fj.setTransform(dart.math.Isometry3(np.eye(3), [0, 0, H]))
    gnd = dyn.Skeleton("ground")
    _, gb = gnd.createWeldJointAndBodyNodePair()
    gs = gb.createShapeNode(dyn.BoxShape([100, 100, 1.0]))
    gs.setRelativeTranslation([0, 0, -0.5])
    gs.createCollisionAspect()
    gd = gs.createDynamicsAspect()
    gd.setFrictionCoeff(2.0)
    gd.setRestitutionCoeff(0.0)
    world.addSkeleton(blk)
    world.addSkeleton(gnd)
    world.setCollisionDetector(dart.collision.FCLCollisionDetector())
    n_set, n, e = round(SETTLE / dt), round(DURATION / dt), every(dt)
    a = drive(dt, n).tolist()
    t0 = time.perf_counter()
    for _ in range(n_set):
        world.step()
    body.getTransform()
    last = None
    for k in range(n):
        if a[k] != last:  # as the adapter: only when the load changes (constant after the pulse)
            world.setGravity([-a[k], 0.0, -G])
            last = a[k]
        world.step()
        if (k + 1) % e == 0:
            body.getTransform()
            body.getAngularVelocity()
    return time.perf_counter() - t0


BARE = {"pybullet": bare_pybullet, "mujoco": bare_mujoco, "dart": bare_dart}


GOAL = 1.3


def housner_scene():
    """The benchmark scene: Housner block, sub-threshold half-sine a = 5.0 m/s², 0.5 s + 5 s, output 1 kHz."""
    scn = housner_scenario(
        excitation={"type": "half_sine", "amplitude": AMP, "phase": "housner_uplift"},
        settle_time=SETTLE,
        duration=DURATION,
        output_dt=OUTPUT_DT,
    )
    return compile_scene(scn)


def overhead(name: str, dt: float = 1e-3, repeat: int = 3, scene=None) -> dict[str, float]:
    """Best-of-``repeat`` wall seconds per simulated second: adapter, bare loop, their ratio, peak θ/α.

    Also the adapter's CPU seconds (process time) of its best run, for a loaded machine.
    """
    scene = scene or housner_scene()
    sim_s = SETTLE + DURATION
    adapter, bare, cpu = math.inf, math.inf, math.inf
    peak = float("nan")
    run_scene(scene, name, {"timestep": dt})  # warm-up: imports, the cached compiled model
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        traj = run_scene(scene, name, {"timestep": dt})
        adapter = min(adapter, time.perf_counter() - t0)
        cpu = min(cpu, time.process_time() - c0)
        peak = float(np.max(np.abs(traj.rocking_angle()))) / math.atan(B / H)
        bare = min(bare, BARE[name](dt))
    return {
        "adapter": adapter / sim_s,
        "adapter_cpu": cpu / sim_s,
        "bare": bare / sim_s,
        "ratio": adapter / bare,
        "peak": peak,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--engines", default="pybullet,mujoco,dart")
    ap.add_argument("--dts", default="1e-3,1e-4")
    args = ap.parse_args()
    scene = housner_scene()
    print(
        f"Housner block, half-sine a = {AMP} m/s² (sub-threshold), {SETTLE} s settling + {DURATION} s; "
        f"best of {args.repeat}; wall seconds per simulated second"
    )
    print(
        f"{'engine':10s} {'dt':>8s} {'adapter':>10s} {'bare loop':>10s} {'overhead':>9s} {'goal':>6s} {'peak θ/α':>9s}"
    )
    for name in args.engines.split(","):
        try:
            get_engine(name)
        except EngineNotAvailable as exc:
            print(f"{name:10s} not available: {exc}")
            continue
        for dt in (float(x) for x in args.dts.split(",")):
            r = overhead(name, dt, args.repeat, scene)
            print(
                f"{name:10s} {dt:8.0e} {r['adapter']:10.4f} {r['bare']:10.4f} {r['ratio']:8.2f}× "
                f"{GOAL:5.1f}× {r['peak']:9.4f}"
            )
    try:
        loop, native = mujoco_multistep_gain(1e-3)
        print(
            f"mujoco settling ({SETTLE} s at dt 1e-3): Python loop {loop * 1e3:.2f} ms, "
            f"mj_step(m, d, n) {native * 1e3:.2f} ms, gain {loop / native:.2f}×"
        )
    except ImportError:
        pass


if __name__ == "__main__":
    main()
