"""MuJoCo adapter: the rock as one free body on a static (or kinematically driven) pedestal.

The model is built with :class:`mujoco.MjSpec` from the :class:`~pbr_xval.scene.Scene` only:

* rock collision: a box geom for a box rock, one box geom per part for the notched block,
  otherwise one mesh geom (MuJoCo collides every mesh as its convex hull) holding the convex
  hull of ``scene.rock.mesh``, or (``collision = "coacd"``) one mesh geom per CoACD part,
  cached on disk;
* mass properties always explicit from the scene (``inertiafromgeom`` false): the body frame
  is the scene frame translated to the COM, the inertial frame is the principal frame
  (diagonalised here), so the body orientation *is* the rotation relative to the rest pose;
* pedestal: a plane geom (box when it must move) or a box with its top at z = 0; ground motion
  as an inertial load (gravity (−a_x, −a_y, −g − a_z) at mid-step, the default) or a pedestal
  on slide joints, qpos/qvel overridden every step with ``qfrc_applied = M·a`` (never mocap).

Pitfalls: ``shared/notes/engines_pybullet_mujoco.md``. ``mujoco`` is imported lazily.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from pbr_xval import quaternions, stepping
from pbr_xval.engine import (
    Capabilities,
    EngineBase,
    EngineSettingsError,
    NotApplicable,
    Trajectory,
    import_engine_package,
)
from pbr_xval.engines._common import COLLISION_CHOICES, cached_model, check_choices, collision_parts
from pbr_xval.linalg3 import mat3_vec, principal_axes
from pbr_xval.stepping import GROUND_MODES, StepBlock, StepperBase, fail, failed_trajectory, run_steps

if TYPE_CHECKING:
    from pbr_xval.scene import Scene

__all__ = ["MuJoCoEngine"]

_INTEGRATORS = ("Euler", "RK4", "implicit", "implicitfast", "discrete")
_SOLVERS = ("PGS", "CG", "Newton")
_CONES = ("pyramidal", "elliptic")


def _import_mujoco() -> Any:
    return import_engine_package("mujoco", "mujoco")


def _mat_to_quat(r: np.ndarray) -> list[float]:
    return [float(x) for x in stepping.matrix_to_quat(r)]


def _dampratio_from_restitution(e: float) -> float:
    """Damping ratio ζ of a linear spring-damper whose rebound coefficient is ``e`` (0 → ζ = 1).

    e = exp(−ζπ/√(1−ζ²)) for ζ < 1; an approximation for MuJoCo, which has no restitution input.
    """
    if e <= 0.0:
        return 1.0
    if e >= 1.0:
        return 0.0
    ln = math.log(e)
    return -ln / math.sqrt(math.pi**2 + ln**2)


class MuJoCoEngine(EngineBase):
    """MuJoCo (``mujoco-core``) rigid-body adapter; see the module docstring."""

    name: ClassVar[str] = "mujoco"
    requires: ClassVar[str | None] = "mujoco"
    # MuJoCo has no restitution coefficient: the faithful profile maps it to the contact damping
    # ratio (linear spring-damper formula), which is approximate and not validated.
    capabilities: ClassVar[Capabilities] = Capabilities(restitution=False)
    #: conformance check name -> reason (none measured to fail in the faithful profile)
    expected_failures: ClassVar[dict[str, str]] = {}

    def profiles(self) -> dict[str, dict[str, Any]]:
        # Hard contact (notes §2.3, §6.3): reproduces 5.637–5.638 and r = 0.850.
        faithful = {
            "timestep": 1e-3,
            "ground_motion": "inertial",  # or "moving_pedestal"
            "pedestal_mass": 1e5,  # kg, moving_pedestal only
            "plane_box_half_extents": [50.0, 50.0, 1.0],  # m, a plane pedestal that must move
            "settle": True,  # settle for scene.settle_time under gravity when starting at rest
            "integrator": "implicitfast",
            "solver": "Newton",
            "iterations": 100,
            "ls_iterations": 50,
            "tolerance": 1e-8,
            "noslip_iterations": 0,
            "cone": "elliptic",
            "impratio": 1.0,
            "condim": 3,
            # [timeconst s, dampratio]; None -> timeconst 2·timestep (the refsafe minimum),
            # dampratio from scene.restitution (1 for restitution 0)
            "solref": [None, None],
            "solimp": [0.999, 0.9999, 0.001, 0.5, 2.0],
            # [sliding, torsional, rolling]; None sliding -> scene.mu_s (MuJoCo has one μ and
            # combines geoms by max: both geoms get it, so the pair has exactly scene.mu_s)
            "friction": [None, 0.0, 0.0],
            "margin": 0.0,
            "multiccd": True,
            "refsafe": True,
            "sleep": False,
            "collision": "auto",  # auto: the scene compiler's choice (scenario [model]) | primitive | boxes | hull | coacd | decimated
            "coacd_threshold": 0.05,
            "coacd_seed": 0,
        }
        # MuJoCo's own defaults (mjOption / mjsGeom defaults of MuJoCo 4.0): only what differs
        default = {
            "timestep": 0.002,
            "integrator": "Euler",
            "cone": "pyramidal",
            "solref": [0.02, 1.0],
            "solimp": [0.9, 0.95, 0.001, 0.5, 2.0],
            "friction": [1.0, 0.005, 0.0001],  # MuJoCo's geom default, not the scene's μ
        }
        return {"faithful": faithful, "engine-default": faithful | default}

    def versions(self) -> dict[str, str]:
        from pbr_xval.version import __version__

        mujoco = _import_mujoco()
        return {"pbr_xval": __version__, "mujoco": mujoco.__version__, "numpy": np.__version__}

    # ------------------------------------------------------------------ checks
    def _check(self, s: dict[str, Any]) -> None:
        choices = {"ground_motion": GROUND_MODES, "integrator": _INTEGRATORS, "solver": _SOLVERS}
        check_choices(
            self.name, s, choices | {"cone": _CONES, "collision": COLLISION_CHOICES, "condim": (1, 3, 4, 6)}
        )
        if len(s["solref"]) != 2 or len(s["solimp"]) != 5 or len(s["friction"]) != 3:
            raise EngineSettingsError("engine 'mujoco': solref needs 2 values, solimp 5, friction 3")

    # ------------------------------------------------------------------ model
    def _build(self, mujoco: Any, scene: Scene, s: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
        dt = float(s["timestep"])
        rock = scene.rock
        moving = s["ground_motion"] == "moving_pedestal"
        vertical = scene.excitation.vertical is not None

        spec = mujoco.MjSpec()
        spec.modelname = "pbr_xval"
        spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
        opt = spec.option
        opt.timestep = dt
        opt.gravity = [0.0, 0.0, -float(scene.gravity)]
        opt.integrator = getattr(mujoco.mjtIntegrator, "mjINT_" + s["integrator"].upper())
        opt.solver = getattr(mujoco.mjtSolver, "mjSOL_" + s["solver"].upper())
        opt.cone = getattr(mujoco.mjtCone, "mjCONE_" + s["cone"].upper())
        opt.iterations = int(s["iterations"])
        opt.ls_iterations = int(s["ls_iterations"])
        opt.tolerance = float(s["tolerance"])
        opt.noslip_iterations = int(s["noslip_iterations"])
        opt.impratio = float(s["impratio"])
        bits = mujoco.mjtDisableBit
        dis = int(bits.mjDSBL_AUTORESET)  # a blow-up must show as NaN, not a silent reset
        dis |= (0 if s["multiccd"] else int(bits.mjDSBL_MULTICCD)) | (
            0 if s["refsafe"] else int(bits.mjDSBL_REFSAFE)
        )
        opt.disableflags = dis
        opt.enableflags = int(mujoco.mjtEnableBit.mjENBL_SLEEP) if s["sleep"] else 0

        tc, dr = s["solref"]
        restitution_model = "dampratio given"
        if dr is None:
            dr = _dampratio_from_restitution(float(scene.restitution))
            restitution_model = f"dampratio {dr:.4g} from restitution {scene.restitution:g}"
        if tc is None:
            tc = 2.0 * dt
        solref = [float(tc), float(dr)]
        solimp = [float(x) for x in s["solimp"]]
        fr = s["friction"]
        friction = [float(scene.mu_s) if fr[0] is None else float(fr[0]), float(fr[1]), float(fr[2])]
        condim = int(s["condim"])
        margin = float(s["margin"])

        def contact(g: Any) -> None:
            g.friction, g.solref, g.solimp, g.condim, g.margin = friction, solref, solimp, condim, margin

        # ---- pedestal
        ped = scene.pedestal
        info: dict[str, Any] = {"moving": moving}
        if ped["kind"] == "plane":
            if moving:
                he = [float(x) for x in s["plane_box_half_extents"]]
                ptype, psize, pkind = mujoco.mjtGeom.mjGEOM_BOX, he, "box (plane pedestal that moves)"
            else:
                he = [0.0, 0.0, 1.0]
                ptype, psize, pkind = mujoco.mjtGeom.mjGEOM_PLANE, he, "plane"
        elif ped["kind"] == "box":
            he = [float(x) for x in ped["half_extents"]]
            ptype, psize, pkind = mujoco.mjtGeom.mjGEOM_BOX, he, "box"
        else:
            raise NotApplicable(
                f"mujoco: pedestal kind {ped['kind']!r} is not supported (MuJoCo would collide a mesh "
                "pedestal as its convex hull)"
            )
        ppos = [0.0, 0.0, 0.0] if ptype == mujoco.mjtGeom.mjGEOM_PLANE else [0.0, 0.0, -psize[2]]
        if moving:
            pbody = spec.worldbody.add_body(name="pedestal")
            pbody.mass = float(s["pedestal_mass"])
            pbody.inertia = [float(s["pedestal_mass"])] * 3
            pbody.gravcomp = 1.0
            axes = [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0)] + ([(0.0, 0.0, 1.0)] if vertical else [])
            for i, ax in enumerate(axes):
                pbody.add_joint(name=f"ped{i}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=list(ax))
            pg = pbody.add_geom(name="pedestal", type=ptype, size=psize, pos=ppos)
        else:
            pg = spec.worldbody.add_geom(name="pedestal", type=ptype, size=psize, pos=ppos)
        contact(pg)
        info["pedestal"] = pkind

        # ---- rock: body frame = scene axes at the COM; principal inertial frame
        com = np.asarray(rock.com, dtype=float)
        body = spec.worldbody.add_body(name="rock", pos=com.tolist())
        body.add_freejoint(name="rock")
        # principal axes without LAPACK: the same bits on every CPU (pbr_xval.linalg3)
        evals, evecs = principal_axes(np.asarray(rock.inertia, dtype=float))
        body.mass = float(rock.mass)
        body.ipos = [0.0, 0.0, 0.0]
        body.iquat = _mat_to_quat(evecs)
        body.inertia = [float(x) for x in evals]
        body.explicitinertial = True

        kind, parts = collision_parts(scene, s["collision"], s["coacd_threshold"], s["coacd_seed"])
        rq = _mat_to_quat(np.asarray(rock.rotation, dtype=float))
        if kind in ("primitive", "boxes"):
            if kind == "primitive":  # collision_parts gives these kinds only when they exist
                assert rock.primitive is not None
                boxes: list[tuple[Any, Any]] = [
                    (rock.mesh.bounds.mean(axis=0), rock.primitive["half_extents"])
                ]
                info.update(collision="box primitive", parts=1)
            else:
                assert rock.box_parts is not None
                boxes = list(rock.box_parts)
                info.update(collision="compound of box geoms", parts=len(boxes))
            for c, h in boxes:
                pos = (np.asarray(c, dtype=float) - com).tolist()
                contact(
                    body.add_geom(
                        type=mujoco.mjtGeom.mjGEOM_BOX, size=[float(x) for x in h], pos=pos, quat=rq
                    )
                )
        else:
            # every MuJoCo mesh geom collides as its convex hull
            info.update(collision=kind, parts=len(parts))
            for i, (pv, pf) in enumerate(parts):
                ms = spec.add_mesh(
                    name=f"rock{i}",
                    uservert=(np.asarray(pv, dtype=float) - com).ravel().tolist(),
                    userface=np.asarray(pf, dtype=np.int64).ravel().tolist(),
                )
                ms.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_EXACT
                g = body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"rock{i}")
                contact(g)
        info["restitution_model"] = restitution_model
        info["solref_used"] = solref
        info["friction_used"] = friction
        model = spec.compile()
        return model, info

    # ------------------------------------------------------------------ simulate
    def simulate(self, scene: Scene, settings: Mapping[str, Any] | None = None) -> Trajectory:
        s = self.resolve_settings(settings)
        self._check(s)
        mujoco = _import_mujoco()
        if scene.rock.shape not in self.capabilities.shapes:
            raise NotApplicable(f"mujoco: rock shape {scene.rock.shape!r} is not supported")
        versions = self.versions()
        try:
            m, info = cached_model(self.name, scene, s, lambda: self._build(mujoco, scene, s))
            info = dict(info)
        except NotApplicable:
            raise
        except Exception as exc:  # model compilation errors (e.g. a degenerate mesh part)
            msg = f"mujoco: model compilation failed: {exc}"
            return failed_trajectory(self.name, scene, msg, s, versions)
        st = _MjStepper(mujoco, m, scene, s, info)
        rec, diag = run_steps(st, scene, float(m.opt.timestep), settle=bool(s["settle"]), name=self.name)
        nw = int(mujoco.mjtWarning.mjNWARNING)
        ws = mujoco.mjtWarning.__members__.values()
        counts = {w.name: int(st.d.warning[int(w)].number) for w in ws if int(w) < nw}
        warnings = {k: v for k, v in counts.items() if v}
        diag.update(ground_motion=s["ground_motion"], mujoco_warnings=warnings)
        if warnings.get("mjWARN_BADQACC"):
            n = warnings["mjWARN_BADQACC"]
            fail(rec, diag["steps"] * st.dt, f"mujoco: bad acceleration (mjWARN_BADQACC × {n})")
        diag.update({f"model_{k}": v for k, v in info.items()})
        return rec.trajectory(self.name, s, versions, diag)


class _MjStepper(StepperBase):
    """MuJoCo side of :func:`pbr_xval.stepping.run_steps` (one MjData per run)."""

    samples_only = True  # reads the state at the output samples only (StepBlock.keep)

    def __init__(self, mujoco: Any, m: Any, scene: Scene, s: dict[str, Any], info: dict[str, Any]) -> None:
        self.mj, self.m, self.scene, self.s = mujoco, m, scene, s
        self.d = d = mujoco.MjData(m)
        self.dt = float(m.opt.timestep)
        self.moving = bool(info["moving"])
        jr = m.body_jntadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "rock")]
        self.qa, self.va = qa, va = int(m.jnt_qposadr[jr]), int(m.jnt_dofadr[jr])
        self.qb, self.vb = np.zeros((0, m.nq)), np.zeros((0, m.nv))
        self.pos, self.quat = d.qpos[qa : qa + 3], d.qpos[qa + 3 : qa + 7]
        self.vlin, self.wbody = d.qvel[va : va + 3], d.qvel[va + 3 : va + 6]
        self.npj = 3 if scene.excitation.vertical is not None else 2
        if self.moving:
            j0 = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "ped0")
            self.pq = pq = int(m.jnt_qposadr[j0])
            pv = int(m.jnt_dofadr[j0])
            self.pqs, self.pvs = d.qpos[pq : pq + self.npj], d.qvel[pv : pv + self.npj]
            self.pfs = d.qfrc_applied[pv : pv + self.npj]
        mujoco.mj_resetData(m, d)
        m.opt.gravity[:] = (0.0, 0.0, -float(scene.gravity))  # a cached model may come from a failed run

    def set_initial(self, com: np.ndarray, rot: np.ndarray, vel: np.ndarray, omega: np.ndarray) -> None:
        self.pos[:] = com
        self.quat[:] = _mat_to_quat(rot)
        self.vlin[:] = vel
        self.wbody[:] = mat3_vec(np.asarray(rot, dtype=float).T, omega)

    def settle(self, n: int) -> None:
        mj, m, d = self.mj, self.m, self.d
        if n and not self.moving:
            mj.mj_step(m, d, n)  # native multi-step: gravity only, no per-step drive
        elif n:
            for _ in range(n):  # hold the pedestal at rest
                self.pqs[:] = self.pvs[:] = 0.0
                mj.mj_step(m, d)
            self.pqs[:] = self.pvs[:] = 0.0

    def state(self) -> tuple[np.ndarray, np.ndarray, float]:
        speed = (
            self.speed(self.vlin, self.wbody, self.scene) if np.all(np.isfinite(self.d.qpos)) else math.inf
        )
        return self.pos.copy(), quaternions.quats_to_mats(self.quat[None])[0].reshape(3, 3), speed

    def begin(self, n: int) -> None:
        scene, dt, npj = self.scene, self.dt, self.npj
        tk = np.arange(n) * dt
        if self.moving:
            acc_mid = np.asarray(scene.excitation.acceleration(tk + 0.5 * dt), dtype=float).reshape(n, 3)
            disp = scene.excitation.displacement(tk).reshape(n, 3)
            self.disp = np.ascontiguousarray(disp - disp[0])[:, :npj].copy()
            self.vel = np.ascontiguousarray(scene.excitation.velocity(tk).reshape(n, 3)[:, :npj]).copy()
            self.frc = float(self.s["pedestal_mass"]) * acc_mid[:, :npj]
            self.vlin += scene.excitation.velocity(0.0)  # the rock moves with the pedestal at t = 0
        else:
            g = stepping.gravity_sequence(scene, tk + 0.5 * dt)
            self.grav_xyz = (g[:, 0].tolist(), g[:, 1].tolist(), g[:, 2].tolist())  # floats: no GC load
            self.x_only = bool(np.all(g[:, 1:] == g[:1, 1:]))  # y, z constant: set once, x per step
            self.m.opt.gravity[1:] = g[0, 1:]  # (when y or z varies, every step sets all three anyway)

    def advance(self, k0: int, k1: int, block: StepBlock) -> None:
        m, d, step, keep, moving = self.m, self.d, self.mj.mj_step, block.keep, self.moving
        grav = m.opt.gravity
        if self.qb.shape[0] < block.size:  # raw qpos / qvel rows, converted once per block
            self.qb, self.vb = np.zeros((block.size, m.nq)), np.zeros((block.size, m.nv))
        qb, vb, qpos, qvel, ncon, pen = self.qb, self.vb, d.qpos, d.qvel, block.ncon, block.pen
        (gx, gy, gz), x_only = getattr(self, "grav_xyz", ((), (), ())), getattr(self, "x_only", False)
        i = 0
        try:
            for k in range(k0, k1):
                if moving:
                    self.pqs[:], self.pvs[:], self.pfs[:] = self.disp[k], self.vel[k], self.frc[k]
                elif x_only:
                    grav[0] = gx[k]
                else:
                    grav[0], grav[1], grav[2] = gx[k], gy[k], gz[k]
                step(m, d)
                if keep is None or keep[k]:  # a sample (or every step): pose, velocity, contacts
                    qb[i], vb[i] = qpos, qvel
                    nc, con = d.ncon, d.contact  # the list bound first: reading .dist is then 2× cheaper
                    ncon[i], pen[i] = nc, (-min(con.dist.tolist()) if nc else 0.0)
                    i += 1
        finally:
            block.n = n = i  # rows complete (a step that raised is not one)
            qa, va = self.qa, self.va
            block.com[:n] = qb[:n, qa : qa + 3]
            if moving:
                block.com[:n, : self.npj] -= qb[:n, self.pq : self.pq + self.npj]
            rot = block.rot[:n] = quaternions.quats_to_mats(qb[:n, qa + 3 : qa + 7])
            # ω in the pedestal frame = R ω_body, element-wise (no BLAS: the same bits on every CPU)
            wb = vb[:n, va + 3 : va + 6]
            for r in range(3):
                block.omega[:n, r] = (
                    rot[:, 3 * r] * wb[:, 0] + rot[:, 3 * r + 1] * wb[:, 1] + rot[:, 3 * r + 2] * wb[:, 2]
                )

    def end(self) -> None:
        if self.moving:
            self.pfs[:] = 0.0
        else:
            self.m.opt.gravity[:] = (0.0, 0.0, -float(self.scene.gravity))
