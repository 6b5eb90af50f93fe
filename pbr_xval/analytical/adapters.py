"""The analytical solutions as engines: ``housner`` and ``curved_base``.

Both answer through the same :class:`~pbr_xval.engine.Engine` protocol as the simulators, so
studies treat them alike. They are planar: the rock rocks in the vertical plane of the shaking
direction d, about the horizontal axis ez × d.

``housner`` variants (setting ``variant``):

* ``exact`` — the nonlinear rocking equation of Makris & Roussos (2000), generalised to any
  body on two pivots, angular-momentum impacts, event-based integration. Housner half-sine
  block: 5.638 m/s².
* ``linearized`` — the slender-block linearisation (Zhang & Makris 2001 eq. 50), uplift at
  g·α. Same block: 5.44 m/s² (Makris & Roussos 2000 report 5.43–5.44).
* ``housner1963`` — Housner's 1963 closed form a = gα√(1 + (ω/p)²) (his eq. 12) for the
  half-sine pulse, which postulates toppling when θ = α at the end of the pulse; the
  trajectory is the linearized response and ``toppled`` is decided by the closed form.
  Same block: 6.62 m/s² (unconservative by 17 %, as Makris & Roussos showed).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from pbr_xval.engine import Capabilities, EngineBase, NotApplicable
from pbr_xval.quaternions import axis_angle_quat
from pbr_xval.trajectory import Event, Trajectory

if TYPE_CHECKING:
    from pbr_xval.scene import Scene

__all__ = ["CurvedBaseEngine", "HousnerEngine"]


def _events(raw: list[dict[str, Any]]) -> list[Event]:
    return [
        Event(e["kind"], float(e["t"]), {k: v for k, v in e.items() if k not in ("kind", "t")}) for e in raw
    ]


def _scipy_version() -> str:
    import scipy

    return scipy.__version__


def _impact_ratio(settings: Mapping[str, Any]) -> float | None:
    """The ``impact_ratio`` setting: None (angular-momentum rule) or a velocity ratio η in [0, 1]."""
    from pbr_xval.engine import EngineSettingsError

    eta = settings.get("impact_ratio")
    if eta is None:
        return None
    try:
        val = float(eta)
    except (TypeError, ValueError):
        raise EngineSettingsError(
            f"impact_ratio: expected a velocity ratio η in [0, 1] or none, got {eta!r}"
        ) from None
    if not (0.0 <= val <= 1.0):
        raise EngineSettingsError(
            f"impact_ratio: expected a velocity ratio η in [0, 1] (θ̇ after / θ̇ before an impact), got {val}; "
            "an energy ratio r corresponds to η = √r"
        )
    return val


def _drive(scene: Scene) -> tuple[Any, Any, tuple[float, ...]]:
    exc = scene.excitation
    h = exc.horizontal
    v = exc.vertical
    accel = h.acceleration
    accel_v = v.acceleration if v is not None else None
    bps = tuple(sorted(set(exc.breakpoints)))
    return accel, accel_v, bps


class _AnalyticalEngine(EngineBase):
    """What the two analytical adapters share: versions, the solver keywords, the trajectory."""

    def versions(self) -> dict[str, str]:
        from pbr_xval.version import __version__

        return {"pbr_xval": __version__, "scipy": _scipy_version(), "numpy": np.__version__}

    @staticmethod
    def _solver_kwargs(scene: Scene, s: Mapping[str, Any], eta: float | None) -> dict[str, Any]:
        """The keywords both solvers take from the scene and the settings (the drive excepted)."""
        _, accel_v, bps = _drive(scene)
        return {
            "g": scene.gravity,
            "accel_v": accel_v,
            "breakpoints": bps,
            "rtol": s["rtol"],
            "atol": s["atol"],
            "max_step": np.inf if s["max_step"] is None else float(s["max_step"]),
            "dense_dt": scene.output_dt,
            "omega_rest": s["omega_rest"],
            "decision": "physical" if scene.toppling.criterion == "physical" else "first_crossing",
            "free_after": scene.excitation_end,
            "impact_ratio": eta,
        }

    def _trajectory(
        self,
        scene: Scene,
        s: dict[str, Any],
        model: str,
        *,
        t: np.ndarray,
        com: np.ndarray,
        quat: np.ndarray,
        omega: np.ndarray,
        events: list[Event],
        diagnostics: dict[str, Any],
    ) -> Trajectory:
        return Trajectory(
            engine=self.name,
            t=t,
            com=com,
            quat=quat,
            omega=omega,
            events=events,
            diagnostics=diagnostics,
            settings=s,
            versions=self.versions(),
            scenario_hash=scene.scenario_hash,
            scene_info=scene.info() | {"model": model},
            excitation_axis=scene.direction.copy(),
        )


class HousnerEngine(_AnalyticalEngine):
    """Planar two-pivot rocking (Housner's block generalised); see the module docstring."""

    name: ClassVar[str] = "housner"
    capabilities: ClassVar[Capabilities] = Capabilities(
        dims=2,
        shapes=frozenset({"box", "notched_block", "mesh"}),
        sliding=False,
        restitution=False,
        vertical=True,
        deterministic=True,
        analytical=True,
    )

    def profiles(self) -> dict[str, dict[str, Any]]:
        return {
            "faithful": {
                "variant": "exact",
                "rtol": 1e-10,
                "atol": 1e-12,
                "max_step": None,
                "omega_rest": 1e-8,
                "impact_ratio": None,
            }
        }

    def simulate(self, scene: Scene, settings: Mapping[str, Any] | None = None) -> Trajectory:
        from pbr_xval.analytical.closed_form import housner1963_halfsine
        from pbr_xval.analytical.rocking import TwoPivotBody, simulate_rocking
        from pbr_xval.motion.pulses import HalfSine

        s = self.resolve_settings(settings)
        variant = s["variant"]
        if variant not in ("exact", "linearized", "housner1963"):
            raise NotApplicable(
                f"housner: unknown variant {variant!r}; expected exact, linearized or housner1963"
            )
        if scene.rock.shape not in self.capabilities.shapes:
            raise NotApplicable(f"housner: rock shape {scene.rock.shape!r} is not a two-pivot body")
        if scene.restitution != 0.0:
            raise NotApplicable(
                "housner: impacts follow the angular-momentum rule (no bounce); set contact.restitution = 0"
            )
        pm = scene.planar_model()
        body = TwoPivotBody(pm.mass, pm.inertia, pm.left, pm.right)
        accel, _, _ = _drive(scene)
        factor = 1.0
        crit = scene.toppling
        if crit.criterion == "critical_tilt":
            factor = crit.factor
        elif crit.criterion == "tilt_angle":
            factor = math.radians(float(crit.angle_deg or 0.0)) / min(body.alpha("left"), body.alpha("right"))
        eta = _impact_ratio(s)
        sol = simulate_rocking(
            body,
            accel,
            scene.duration,
            variant="linearized" if variant == "housner1963" else variant,
            theta0=scene.theta0,
            omega0=scene.omega0,
            topple_factor=factor,
            down_angle=math.radians(crit.down_angle_deg),
            **self._solver_kwargs(scene, s, eta),
        )
        events = _events(sol.events)
        diagnostics: dict[str, Any] = {
            "toppling_undecided": sol.undecided,
            "n_impacts": sol.n_impacts,
            "peak_theta_ratio": sol.peak_theta_ratio,
            "rhs_evals": sol.rhs_evals,
            "alpha_left": body.alpha("left"),
            "alpha_right": body.alpha("right"),
            "p_left": body.p("left", scene.gravity),
            "p_right": body.p("right", scene.gravity),
            "impact_ratio_landing_left": body.impact_ratio("left") if eta is None else eta,
            "impact_ratio_landing_right": body.impact_ratio("right") if eta is None else eta,
            "impact_rule": "angular momentum (Housner 1963)"
            if eta is None
            else f"prescribed velocity ratio η = {eta}",
        }
        t, theta, omega = sol.t, sol.theta, sol.omega
        if variant == "housner1963":
            h = scene.excitation.horizontal
            if not isinstance(h, HalfSine) or scene.excitation.vertical is not None:
                raise NotApplicable(
                    "housner1963: Housner's closed form exists only for a horizontal half-sine pulse"
                )
            # a positive pulse tips the block toward -d: the left pivot
            a_crit = housner1963_halfsine(
                body.alpha("left"), body.p("left", scene.gravity), 2 * math.pi * h.frequency, scene.gravity
            )
            diagnostics["closed_form_threshold"] = a_crit
            diagnostics["linearized_toppled"] = sol.toppled
            events = [e for e in events if e.kind != "toppled"]
            if h.amplitude >= a_crit:
                t_end_pulse = float(h.duration)
                events.append(
                    Event("toppled", t_end_pulse, {"rule": "Housner 1963: θ = α at the end of the pulse"})
                )
                keep = t <= t_end_pulse
                t, theta, omega = t[keep], theta[keep], omega[keep]
        com, quat, omv = self._kinematics(scene, body, theta, omega)
        return self._trajectory(
            scene,
            s,
            f"two-pivot rocking, {variant}",
            t=t,
            com=com,
            quat=quat,
            omega=omv,
            events=events,
            diagnostics=diagnostics,
        )

    @staticmethod
    def _kinematics(scene: Scene, body: Any, theta: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, ...]:
        d, e, ez = scene.direction, scene.rocking_axis, np.array([0.0, 0.0, 1.0])
        g0 = scene.rock.com
        right = theta >= 0
        px = np.where(right, body.right[0], body.left[0])
        pz = np.where(right, body.right[1], body.left[1])
        # vector from pivot to COM at rest, in (d, z) components, rotated by θ about e
        vd, vz = -px, -pz
        c, s = np.cos(theta), np.sin(theta)
        rd = vd * c + vz * s
        rz = -vd * s + vz * c
        com = g0[None, :] + (px + rd)[:, None] * d[None, :] + (pz + rz)[:, None] * ez[None, :]
        quat = axis_angle_quat(e, theta)
        omv = omega[:, None] * e[None, :]
        return com, quat, omv


class CurvedBaseEngine(_AnalyticalEngine):
    """The seed's curved-base block (science.md §8): rolling on circular arcs, flat slap at θ = 0."""

    name: ClassVar[str] = "curved_base"
    capabilities: ClassVar[Capabilities] = Capabilities(
        dims=2,
        shapes=frozenset({"curved_base"}),
        sliding=False,
        restitution=False,
        vertical=True,
        deterministic=True,
        analytical=True,
    )

    def profiles(self) -> dict[str, dict[str, Any]]:
        return {
            "faithful": {
                "rtol": 1e-11,
                "atol": 1e-13,
                "max_step": None,
                "clamp": 5.0,
                "omega_rest": 1e-8,
                "impact_ratio": None,
            }
        }

    def simulate(self, scene: Scene, settings: Mapping[str, Any] | None = None) -> Trajectory:
        from pbr_xval.analytical.curved_base import CurvedBaseLamina, simulate_curved_base
        from pbr_xval.scenario import CurvedBaseRock

        s = self.resolve_settings(settings)
        rock = scene.scenario.rock
        if not isinstance(rock, CurvedBaseRock):
            raise NotApplicable(f"curved_base: needs a curved_base rock, got {scene.rock.shape!r}")
        body_x = scene.rock.rotation[:, 0]
        if abs(abs(float(body_x @ scene.direction)) - 1.0) > 1e-9:
            raise NotApplicable(
                "curved_base: the shaking must lie in the plane of the profile (azimuth = rock yaw)"
            )
        sign = float(np.sign(body_x @ scene.direction))
        area_depth = None
        lam = CurvedBaseLamina(rock.H, rock.r, rock.h, depth=rock.depth, density=1.0)
        if rock.density is not None:
            lam = CurvedBaseLamina(rock.H, rock.r, rock.h, depth=rock.depth, density=rock.density)
        else:
            assert rock.mass is not None  # the scenario requires density or mass
            area_depth = lam.mass  # density 1 → volume
            lam = CurvedBaseLamina(rock.H, rock.r, rock.h, depth=rock.depth, density=rock.mass / area_depth)
        accel, _, _ = _drive(scene)
        drive = accel if sign > 0 else (lambda t: -accel(t))
        sol = simulate_curved_base(
            lam,
            drive,
            scene.duration,
            theta0=sign * scene.theta0,
            omega0=sign * scene.omega0,
            clamp=s["clamp"],
            **self._solver_kwargs(scene, s, _impact_ratio(s)),
        )
        events = _events(sol.events)
        crit = scene.toppling
        if crit.criterion == "com_displacement":
            events = [e for e in events if e.kind != "toppled"]
            over = np.nonzero(np.abs(sol.x_com) >= crit.distance)[0]
            if over.size:
                events.append(Event("toppled", float(sol.t[over[0]]), {"rule": "com_displacement"}))
        theta = sign * sol.theta
        d, e, ez = scene.direction, scene.rocking_axis, np.array([0.0, 0.0, 1.0])
        z0 = lam.y_G0
        com = (
            scene.rock.com[None, :]
            + (sign * sol.x_com)[:, None] * d[None, :]
            + (sol.z_com - z0)[:, None] * ez[None, :]
        )
        return self._trajectory(
            scene,
            s,
            "curved base, rolling without slip (science.md §8)",
            t=sol.t,
            com=com,
            quat=axis_angle_quat(e, theta),
            omega=(sign * sol.omega)[:, None] * e[None, :],
            events=events,
            diagnostics={
                "n_impacts": sol.n_impacts,
                "peak_theta_ratio": sol.peak_theta_ratio,
                "peak_com_disp": sol.peak_com_disp,
                "critical_angle": lam.critical_angle,
                "uplift_accel": lam.uplift_accel(scene.gravity),
                "impact_ratio": lam.impact_ratio,
                "rhs_evals": sol.rhs_evals,
                "mass_exact": lam.mass,
                "y_G0_exact": z0,
            },
        )
