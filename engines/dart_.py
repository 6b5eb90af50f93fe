"""DART (``dartpy`` 6.20) adapter.

The rock is one free body whose frame sits at the centre of mass with the scene axes at rest;
its mass, COM and full 3×3 inertia come from the :class:`~pbr_xval.scene.Scene` (DART accepts a
full inertia tensor, so no diagonalisation or frame rotation is needed). Collision geometry:

* box rock → ``BoxShape``;
* notched block → a compound of ``BoxShape`` children (``scene.rock.box_parts``);
* curved base / mesh → ``MeshShape`` of the convex hull of ``scene.rock.mesh`` (``collision =
  "hull"``), of each CoACD part (``"coacd"``, parts cached on disk) or of the mesh itself
  (``"mesh"``; FCL and ODE collide non-convex meshes correctly, notes §5). dartpy cannot build
  a mesh from arrays, so OBJ files are written to the cache directory (``PBR_XVAL_CACHE`` or
  ``~/.cache/pbr_xval``) and loaded through a URDF string.

The pedestal is a welded box (top at z = 0) in ``ground_motion = "inertial"`` mode, where the
pedestal acceleration a(t + dt/2) enters as tilted gravity (−a_x, −a_y, −g − a_z) before every
step. In ``"moving_pedestal"`` mode the pedestal rides a 3-DOF ``TranslationalJoint`` with an
``ACCELERATION`` actuator (kinematic: prescribed acceleration, non-reactive) commanded with
a(t + dt/2) every step; positions are reported relative to the pedestal.

Measured ground truth and pitfalls: ``/work/shared/notes/engines_dart.md``. The important ones:
sleeping is on by default and must be off; ``World.step()`` clears joint commands; DART
combines friction with min(μ1, μ2) and restitution as e1·e2; the LCP solver reports failures
on stderr only (captured here and counted in the diagnostics).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from pbr_xval.engine import (
    Capabilities,
    EngineBase,
    EngineSettingsError,
    NotApplicable,
    Trajectory,
    import_engine_package,
)
from pbr_xval.engines import _common as common
from pbr_xval.engines._dart_model import (
    expmap_to_mats,
    freejoint_velocity_is_world,
    load_mesh_shapes,
    shape_node,
)
from pbr_xval.stepping import (
    GROUND_MODES,
    StepBlock,
    StepperBase,
    failed_trajectory,
    gravity_sequence,
    run_steps,
)

if TYPE_CHECKING:
    from pbr_xval.scene import Scene

__all__ = ["DartEngine"]

_DETECTORS = ("fcl", "ode", "dart", "bullet")
_LCP_SOLVERS = ("dantzig", "pgs", "nsgs", "fbf")
#: substrings of DART's stderr lines that signal a failed LCP solve
_LCP_FAILURE_NEEDLES = ("failed to find a solution",)


def _import_dart() -> Any:
    return import_engine_package("dart", "dartpy")


class DartEngine(EngineBase):
    """DART rigid-body adapter (Featherstone dynamics, boxed-LCP contacts); see the module docstring."""

    name: ClassVar[str] = "dart"
    requires: ClassVar[str | None] = "dartpy"
    capabilities: ClassVar[Capabilities] = Capabilities()  # every shape, sliding, restitution, vertical
    #: conformance check name -> reason (with the measured size)
    expected_failures: ClassVar[dict[str, str]] = {}

    # ------------------------------------------------------------------ settings
    def profiles(self) -> dict[str, dict[str, Any]]:
        common = {
            "timestep": 1e-3,  # s; DART's World default is also 1e-3
            "ground_motion": "inertial",  # "inertial" (tilted gravity) | "moving_pedestal"
            "settle": True,  # settle scene.settle_time s under gravity before t = 0 (only when starting at rest)
            "collision_detector": "fcl",  # "fcl" (DART's default) | "ode" | "dart" | "bullet"
            "lcp_solver": "dantzig",  # "dantzig" (default; PGS fallback) | "pgs" | "nsgs" | "fbf"
            "pgs_iterations": 30,  # PgsBoxedLcpSolverOption.mMaxIteration (the PGS fallback, or primary)
            "split_impulse": False,  # BoxedLcpConstraintSolver default
            "collision": "auto",  # auto: the scene compiler's choice | primitive | boxes | hull | coacd | decimated | mesh (raw, non-convex)
            "coacd_threshold": 0.05,
            "coacd_seed": 0,
            "plane_half_extents": [50.0, 50.0, 0.5],  # m, the box standing in for a "plane" pedestal
            "pedestal_mass": 1.0e5,  # kg, moving pedestal (prescribed acceleration: the mass does not act)
            # ERP 0.01, max ERV 1e-3 m/s, CFM 1e-5 and the 0.1 m/s bounce threshold are compile-time
            # constants of DART's ContactConstraint; they cannot be set from Python.
        }
        faithful = {
            **common,
            "friction": "scene",  # μ on both shapes; DART takes min(μ1, μ2) → μ_s of the scene
            "restitution": "scene",  # e on the rock, 1 on the pedestal; DART multiplies → e of the scene
            "sleep": False,
            "sleep_linear_threshold": 0.01,  # m/s
            "sleep_angular_threshold": 0.05,  # rad/s
            "sleep_time": 0.5,  # s
        }
        engine_default = {
            **faithful,
            # DART has no notion of a shaking base: the DART way (notes §2) is a ground body driven by
            # a joint with an ACCELERATION actuator. With DART's default sleeping on, the rock falls
            # asleep while settling and that pedestal does not wake it (it never rocks); in "inertial"
            # mode the changing gravity wakes it and this profile gives the faithful answer (5.6385).
            "ground_motion": "moving_pedestal",
            "friction": 1.0,  # DynamicsAspect default friction coefficient, on each shape
            "restitution": 0.0,  # DynamicsAspect default restitution, on each shape
            "sleep": True,  # DART deactivation is on by default
        }
        return {"faithful": faithful, "engine-default": engine_default}

    def versions(self) -> dict[str, str]:
        dart = _import_dart()
        from pbr_xval.version import __version__

        return {"pbr_xval": __version__, "dartpy": getattr(dart, "__version__", "?"), "numpy": np.__version__}

    def _check(self, s: Mapping[str, Any]) -> None:
        c = {"ground_motion": GROUND_MODES, "collision_detector": _DETECTORS, "lcp_solver": _LCP_SOLVERS}
        common.check_choices(self.name, s, c | {"collision": common.COLLISION_CHOICES})

    # ------------------------------------------------------------------ model
    def _rock_shapes(
        self, dart: Any, scene: Scene, s: Mapping[str, Any]
    ) -> tuple[list[tuple[Any, Any, Any]], str]:
        """[(shape, rotation (3, 3), translation (3,)) in the body frame], model description."""
        D = dart.dynamics
        rock = scene.rock
        com = np.asarray(rock.com, dtype=float)
        kind, parts = common.collision_parts(scene, s["collision"], s["coacd_threshold"], s["coacd_seed"])
        if kind == "primitive":
            assert rock.primitive is not None  # collision_parts gives this kind only when it exists
            he = np.asarray(rock.primitive["half_extents"], dtype=float)
            centre = 0.5 * (rock.mesh.bounds[0] + rock.mesh.bounds[1])
            return [(D.BoxShape(2.0 * he), np.asarray(rock.rotation, float), centre - com)], "box primitive"
        if kind == "boxes":
            assert rock.box_parts is not None  # collision_parts gives this kind only when it exists
            out = [
                (
                    D.BoxShape(2.0 * np.asarray(h, float)),
                    np.asarray(rock.rotation, float),
                    np.asarray(c, float) - com,
                )
                for c, h in rock.box_parts
            ]
            return out, f"compound of {len(out)} boxes"
        # FCL collides a MeshShape as the triangle mesh itself (non-convex allowed)
        paths = [common.write_obj(np.asarray(v, float) - com, f, f"dart_{kind}") for v, f in parts]
        desc = {"hull": "convex hull mesh", "mesh": "triangle mesh (non-convex)"}.get(
            kind, f"{kind}, {len(paths)} parts"
        )
        shapes = load_mesh_shapes(dart, paths)
        return [(sh, np.eye(3), np.zeros(3)) for sh in shapes], desc

    def _pedestal_shape(self, dart: Any, scene: Scene, s: Mapping[str, Any]) -> tuple[Any, np.ndarray, str]:
        D = dart.dynamics
        ped = scene.pedestal
        if ped["kind"] in ("plane", "box"):
            plane = ped["kind"] == "plane"
            he = np.asarray(
                ped["half_extents"] if ped["kind"] == "box" else s["plane_half_extents"], dtype=float
            )
            desc = "box standing in for the plane" if plane else "box"
            return D.BoxShape(2.0 * he), np.array([0.0, 0.0, -he[2]]), desc
        if ped["kind"] == "mesh":
            pm = ped["mesh"]
            path = common.write_obj(np.asarray(pm.vertices, float), np.asarray(pm.faces), "dart_pedestal")
            return load_mesh_shapes(dart, [path])[0], np.zeros(3), "triangle mesh"
        raise NotApplicable(f"dart: unknown pedestal kind {ped['kind']!r}")

    # ------------------------------------------------------------------ run
    def simulate(self, scene: Scene, settings: Mapping[str, Any] | None = None) -> Trajectory:
        s = self.resolve_settings(settings)
        self._check(s)
        dart = _import_dart()
        D = dart.dynamics
        versions = self.versions()
        if scene.rock.shape not in self.capabilities.shapes:
            raise NotApplicable(f"dart: rock shape {scene.rock.shape!r} is not supported")

        dt, g, rock = float(s["timestep"]), float(scene.gravity), scene.rock
        moving = s["ground_motion"] == "moving_pedestal"
        mass, inertia, com0 = float(rock.mass), np.asarray(rock.inertia, float), np.asarray(rock.com, float)
        mu_rock = mu_ped = float(scene.mu_s) if s["friction"] == "scene" else float(s["friction"])
        e_rock, e_ped = (scene.restitution, 1.0) if s["restitution"] == "scene" else (s["restitution"],) * 2
        e_rock, e_ped = float(e_rock), float(e_ped)

        diag: dict[str, Any] = {}
        try:
            # ---- world
            world = dart.simulation.World()
            world.setTimeStep(dt)
            world.setGravity(np.array([0.0, 0.0, -g]))
            opts = world.getDeactivationOptions()
            opts.mEnabled, opts.mTimeUntilSleep = bool(s["sleep"]), float(s["sleep_time"])
            opts.mLinearSpeedThreshold = float(s["sleep_linear_threshold"])
            opts.mAngularSpeedThreshold = float(s["sleep_angular_threshold"])
            world.setDeactivationOptions(opts)

            # ---- rock
            rskel = D.Skeleton("rock")
            fj, body = rskel.createFreeJointAndBodyNodePair()
            shapes, model = self._rock_shapes(dart, scene, s)
            for shape, rot, pos in shapes:
                shape_node(body, shape, rot, pos, mu_rock, e_rock)
            body.setInertia(D.Inertia(mass, np.zeros(3), inertia))

            # ---- pedestal
            pskel = D.Skeleton("pedestal")
            if moving:
                pj, pbody = pskel.createTranslationalJointAndBodyNodePair()
                pj.setActuatorType(D.ActuatorType.ACCELERATION)
                pm = float(s["pedestal_mass"])
                pbody.setInertia(D.Inertia(pm, np.zeros(3), np.eye(3) * pm))
            else:
                pj, pbody = pskel.createWeldJointAndBodyNodePair()
            pshape, poff, pdesc = self._pedestal_shape(dart, scene, s)
            shape_node(pbody, pshape, np.eye(3), poff, mu_ped, e_ped)

            for sk in (rskel, pskel):
                world.addSkeleton(sk)
            det = {"fcl": "FCL", "ode": "Ode", "dart": "DART", "bullet": "Bullet"}[s["collision_detector"]]
            world.setCollisionDetector(getattr(dart.collision, f"{det}CollisionDetector")())
            cs = world.getConstraintSolver()
            cs.setSplitImpulseEnabled(bool(s["split_impulse"]))
            pgs_opt = dart.constraint.PgsBoxedLcpSolverOption()
            pgs_opt.mMaxIteration = int(s["pgs_iterations"])
            sec = cs.getSecondaryBoxedLcpSolver()
            if sec is not None:
                sec.setOption(pgs_opt)
            if s["lcp_solver"] == "pgs":  # the PGS solver alone (primary, no fallback)
                cs.setSecondaryBoxedLcpSolver(None)
                cs.setBoxedLcpSolver(sec)
            elif s["lcp_solver"] in ("nsgs", "fbf"):
                cs.setBoxedLcpSolver(
                    getattr(dart.constraint, f"{s['lcp_solver'].capitalize()}FrictionSolver")()
                )

            fj.setTransform(dart.math.Isometry3(np.eye(3), com0))  # the rest pose; run_steps tilts
        except (NotApplicable, EngineSettingsError):
            raise
        except Exception as exc:  # engine error while building: a failed run, not an exception
            msg = f"dart: building the model failed: {exc!r}"
            return failed_trajectory(self.name, scene, msg, s, versions)

        diag.update(
            rock_model=model,
            rock_parts=len(shapes),
            pedestal_model=pdesc,
            ground_motion=s["ground_motion"],
            effective_friction=min(mu_rock, mu_ped),
            effective_restitution=e_rock * e_ped,
            friction_note="DART has one friction coefficient: mu_s is used for static and dynamic friction",
        )
        if rock.shape in ("mesh", "curved_base") and s["collision_detector"] in ("dart", "bullet"):
            diag["warning"] = "the DART-native and Bullet detectors make wrong mesh contacts (notes §5)"

        st = _DartStepper(dart, world, scene, fj, body, rskel, pj, moving)
        cap = common.StderrCapture()
        with cap.capture():
            rec, loop = run_steps(st, scene, dt, settle=bool(s["settle"]), name=self.name)
        lines = cap.text.splitlines()
        diag.update(
            loop, dart_stderr_lines=len(lines), dart_stderr_first_line=lines[0][:200] if lines else ""
        )
        diag["dart_lcp_failure_lines"] = sum(
            1 for ln in lines if any(nd in ln for nd in _LCP_FAILURE_NEEDLES)
        )
        return rec.trajectory(self.name, s, versions, diag)


class _DartStepper(StepperBase):
    """DART side of :func:`pbr_xval.stepping.run_steps` (one World per run)."""

    samples_only = True  # reads the state at the output samples only (StepBlock.keep)

    def __init__(
        self, dart: Any, world: Any, scene: Scene, fj: Any, body: Any, rskel: Any, pj: Any, moving: bool
    ) -> None:
        self.dart, self.world, self.scene, self.fj, self.body = dart, world, scene, fj, body
        self.rskel, self.pj, self.moving = rskel, pj, moving
        self.dt = float(world.getTimeStep())

    def set_initial(self, com: np.ndarray, rot: np.ndarray, vel: np.ndarray, omega: np.ndarray) -> None:
        self.fj.setTransform(self.dart.math.Isometry3(rot, com))
        self.fj.setLinearVelocity(vel)
        self.fj.setAngularVelocity(omega)

    def settle(self, n: int) -> None:
        zero3 = np.zeros(3)
        for _ in range(n):  # gravity only, pedestal at rest
            if self.moving:
                self.pj.setCommands(zero3)
            self.world.step()

    def state(self) -> tuple[np.ndarray, np.ndarray, float]:
        T, b = self.body.getTransform(), self.body
        speed = self.speed(b.getLinearVelocity(), b.getAngularVelocity(), self.scene)
        return T.translation(), T.rotation(), speed

    def begin(self, n: int) -> None:
        scene, dt = self.scene, self.dt
        t_mid = (np.arange(n) + 0.5) * dt
        self.acc = np.ascontiguousarray(np.asarray(scene.excitation.acceleration(t_mid), float).reshape(n, 3))
        self.grav = gravity_sequence(scene, t_mid)
        self.grav_l, self.last = self.grav.tolist(), None
        if self.moving:
            # the pedestal starts at the excitation's displacement/velocity at t = 0; the rock rides along
            d0 = np.asarray(scene.excitation.displacement(0.0), dtype=float).reshape(3)
            v0 = np.asarray(scene.excitation.velocity(0.0), dtype=float).reshape(3)
            if np.any(d0 != 0.0) or np.any(v0 != 0.0):
                self.pj.setPositions(d0)
                self.pj.setVelocities(v0)
                T = self.body.getTransform()
                self.fj.setTransform(self.dart.math.Isometry3(T.rotation(), T.translation() + d0))
                self.fj.setLinearVelocity(self.body.getLinearVelocity() + v0)
        # FreeJoint generalised velocities are (ω, v) in world coordinates in dartpy 6.20;
        # reading them (1 µs) is 4× cheaper than BodyNode.getAngularVelocity(); checked here.
        self.fast_omega = freejoint_velocity_is_world(self.dart)
        # the pose from the 6 free-joint coordinates (0.5 µs) instead of getTransform (2.3 µs) when
        # that gives getTransform's matrix bit for bit (checked here: the rock's joint has no offset)
        x, T = self.rskel.getPositions(), self.body.getTransform()
        rot_ok = np.array_equal(expmap_to_mats(x[None, :3])[0], T.rotation().ravel())
        self.fast_pose = bool(len(x) == 6 and rot_ok and np.array_equal(x[3:], T.translation()))

    def advance(self, k0: int, k1: int, block: StepBlock) -> None:
        world, body, pj, moving, acc, grav = self.world, self.body, self.pj, self.moving, self.acc, self.grav
        rskel, grav_l, keep, fast = self.rskel, self.grav_l, block.keep, self.fast_pose
        res, ncon, pen, size = world.getLastCollisionResult, block.ncon, block.pen, block.size
        X, V, PP = [None] * size, [None] * size, [None] * size
        pose = rskel.getPositions if fast else (lambda: body.getTransform().matrix())
        velo = rskel.getVelocities if self.fast_omega else body.getAngularVelocity
        i = 0
        try:
            for k in range(k0, k1):
                if moving:
                    pj.setCommands(acc[k])
                elif grav_l[k] != self.last:
                    world.setGravity(grav[k])
                    self.last = grav_l[k]
                world.step()
                if keep is not None and not keep[k]:
                    continue  # between samples: nothing read
                X[i], V[i] = pose(), velo()  # raw per sample, converted once per block
                if moving:
                    PP[i] = pj.getPositions()
                cs = res().getContacts()
                ncon[i] = nc = len(cs)
                pen[i] = max([c.penetrationDepth for c in cs]) if nc else 0.0
                i += 1
        finally:
            block.n = i
            if i:
                x = np.array(X[:i])
                block.rot[:i] = expmap_to_mats(x[:, :3]) if fast else x[:, :3, :3].reshape(i, 9)
                block.com[:i] = x[:, 3:] if fast else x[:, :3, 3]
                if moving:
                    block.com[:i] -= np.array(PP[:i])
                block.omega[:i] = np.array(V[:i])[:, :3]
