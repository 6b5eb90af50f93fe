"""One-line, unit-carrying descriptions of what a report ran: a scenario, an engine's settings.

>>> from pbr_xval.scenario import load_scenario
>>> describe_scenario(load_scenario("examples/housner_halfsine.toml"))  # doctest: +SKIP
'box 0.4 × 0.4 × 1.2 m, 2400 kg/m³ (461 kg), α = 18.43°; μ = 2, e = 0; half-sine pulse a = 5 m/s², f = 1 Hz; 5 s, output every 1 ms'
"""

from __future__ import annotations

import math
from typing import Any

from pbr_xval import units

__all__ = ["describe_excitation", "describe_scenario"]


def _g(x: Any) -> str:
    return f"{float(x):.4g}"


def _q(key: str, value: Any) -> str:
    u = units.unit(key)
    return f"{_g(value)} {u}".strip() if isinstance(value, int | float) else str(value)


def _dt(x: float) -> str:
    return f"{x * 1e3:.4g} ms" if x < 0.1 else f"{x:.4g} s"


def describe_excitation(exc: Any) -> str:
    """``half-sine pulse a = 5 m/s², f = 1 Hz``; other motions: their numeric fields with units."""
    t = getattr(exc, "type", "")
    if t == "half_sine":
        return f"half-sine pulse a = {_q('amplitude', exc.amplitude)}, f = {_q('frequency', exc.frequency)}"
    if t == "sawtooth":
        return (
            f"triangular velocity pulse PGV = {_q('pgv', exc.pgv)}, T = {_q('period', exc.period)}, "
            f"skew {_g(exc.skew)}"
        )
    if t == "record":
        s = f"record {exc.path}"
        if exc.target_pga:
            s += f" scaled to PGA {_q('pga', exc.target_pga)}"
        elif exc.target_pgv:
            s += f" scaled to PGV {_q('pgv', exc.target_pgv)}"
        elif exc.scale != 1:
            s += f" × {_g(exc.scale)}"
        return s
    parts = []
    data = exc.model_dump() if hasattr(exc, "model_dump") else {}
    for k, v in data.items():
        if k in ("type", "azimuth_deg", "vertical", "start_time") or not isinstance(v, int | float):
            continue
        parts.append(f"{units.label(k, with_unit=False)} {_q(k, v)}")
    return f"{str(t).replace('_', '-')} " + ", ".join(parts)


def describe_scenario(scn: Any) -> str:
    """Rock (size, density, mass, critical angle), contact, ground motion and duration, in one line."""
    rock = scn.rock
    shape = rock.shape
    if shape == "box":
        he = rock.half_extents
        geo = f"box {_g(2 * he[0])} × {_g(2 * he[1])} × {_g(2 * he[2])} m"
    elif shape == "curved_base":
        geo = f"curved-base block H = {_g(rock.H)} m, h = {_g(rock.h)} m, r = {_g(rock.r)} m, depth {_g(rock.depth)} m"
    elif shape == "mesh":
        geo = f"mesh rock {rock.path}"
    else:
        geo = str(shape).replace("_", " ")
    if getattr(rock, "density", None):
        geo += f", {_g(rock.density)} kg/m³"
    try:
        from pbr_xval.scene import compile_scene

        scene = compile_scene(scn)
        alpha = min(scene.alpha)
        m = float(scene.rock.mass)
        geo += f" ({m:,.0f} kg)" if m >= 1000 else f" ({m:.4g} kg)"
        geo += f", α = {math.degrees(alpha):.2f}°"
    except Exception:  # a description must never fail a report
        pass
    c = scn.contact
    contact = f"μ = {_g(c.friction_static)}"
    if c.friction_dynamic is not None and c.friction_dynamic != c.friction_static:
        contact += f" (μ_d = {_g(c.friction_dynamic)})"
    contact += f", e = {_g(c.restitution)}"
    motion = describe_excitation(scn.excitation)
    run = f"{_g(scn.duration)} s simulated"
    if getattr(scn, "output_dt", None):
        run += f", output every {_dt(scn.output_dt)}"
    return "; ".join([geo, contact, motion, run])
