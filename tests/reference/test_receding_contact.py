"""A resting contact that recedes slower than ``separation_velocity`` (issue 23, fifteenth pass of
``reference/PERFORMANCE.md``).

Such a contact stays in the resting set (deviation 7 of :mod:`pbr_xval.reference`), so it carries
a force that keeps its relative acceleration at zero. Its velocity was not stabilised (only
approaching normal velocities were), so a contact force held a separating contact's velocity
constant: a rigid creep that gravity never stopped. On SP2 test 596 the rock, at rest after its
last rock, turned at 6.4e-6 rad/s about an edge for the last 30 s of the record (one node rising
at 5e-7 m/s), unheld and stepped, at three times the run's cost. The velocity stabilisation
(deviation 6) now removes a resting contact's small normal velocity in either direction.

Reference: energy. A block at rest on its base, given an initial rocking rate ω₀ about an edge
with no ground motion, can rise at most to θ_max = I_O ω₀² / (2 m g R sin α) (its kinetic energy
turned into potential energy; θ_max ≈ 1.4e-13 rad for ω₀ = 1e-6 rad/s), and it cannot keep
turning at ω₀: gravity's moment about the edge opposes the motion.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pbr_xval import conformance as conf
from pbr_xval.reference import kernel
from pbr_xval.runner import run_scene
from pbr_xval.scene import compile_scene

G = 9.81
B, H = 0.2, 0.6  # the conformance block's half width and half height, m


@pytest.mark.parametrize("omega0", [1e-6, 2e-6])
def test_a_slowly_lifting_block_falls_back(omega0: float) -> None:
    """ω₀ lifts the far edge at 2 b ω₀ = 0.4–0.8 µm/s, below ``separation_velocity`` (1 µm/s):
    the block stops turning (before: it turned at ω₀ for the whole run, its tilt growing
    linearly to 2.9e-6 rad at 2.9 s, 2e7 times θ_max)."""
    scene = compile_scene(
        conf.housner_scenario(duration=3.0, initial={"omega": omega0}, excitation={"type": "none"})
    )
    traj = run_scene(scene, "reference")
    assert traj.ok
    R = math.hypot(B, H)
    alpha = math.atan(B / H)
    theta_max = (4.0 / 3.0) * R**2 * omega0**2 / (2.0 * G * R * math.sin(alpha))  # I_O = 4/3 m R²
    dt = 1e-3  # the faithful profile's step: one step at ω₀ before the stabilisation acts
    tilt = np.abs(traj.rocking_angle())
    assert tilt.max() <= theta_max + omega0 * dt
    late = traj.t >= 0.5
    assert np.linalg.norm(traj.omega[late], axis=1).max() <= 1e-12


def test_contact_set_stabilises_receding_and_approaching_contacts() -> None:
    """The stabilisation term of a resting contact's normal row is v_n / Δt for a receding
    (0 < v_n ≤ v_sep) as for an approaching contact, zero inside the 1e-8 m/s dead band; a node
    receding faster than v_sep is not a resting contact."""
    nodes = np.array([[0.1, 0.1, -0.6], [-0.1, 0.1, -0.6], [0.1, -0.1, -0.6], [-0.1, -0.1, -0.6]])
    gaps = np.zeros(4)
    # (n, x, y) per node: receding 5e-7, approaching -5e-7, inside the dead band, receding 2e-6
    vel = np.array([[5e-7, 0.0, 0.0], [-5e-7, 0.0, 0.0], [5e-9, 0.0, 0.0], [2e-6, 0.0, 0.0]])
    dt = 1e-3
    idx, slide, _, stab = kernel.contact_set(gaps, vel, nodes, np.arange(4), 1e-5, 1e-6, 1e-4, 0.6, dt, False)
    assert idx.tolist() == [0, 1, 2] and not slide.any()
    assert stab[0::3].tolist() == [5e-7 / dt, -5e-7 / dt, 0.0]
