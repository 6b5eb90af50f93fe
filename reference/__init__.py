"""The ``reference`` engine: the seed paper's rigid-body LCP solver (Veeraraghavan & Krishnan, §3).

Modules, to read beside the paper's Section 3:

* :mod:`~pbr_xval.reference.adapter` — the adapter (settings, the time loop, step-backs, events);
* :mod:`~pbr_xval.reference.dynamics` — state (u_cm, u̇_cm, R, l), eqs. 3.1–3.4, contact
  detection within ±ε, collisions (eq. 3.5), resting contact (eqs. 3.6–3.7), in NumPy;
* :mod:`~pbr_xval.reference.kernel` — the same step compiled with numba (``compiled = True``,
  the default), the active-set resting solve and the support-hull reduction;
* :mod:`~pbr_xval.reference.pivoting` — Lemke and Dantzig/Baraff pivoting (eq. 3.5);
* :mod:`~pbr_xval.reference.selection` — choosing among non-unique impact solutions;
* :mod:`~pbr_xval.reference.cone` — the iterative Coulomb-cone solver and the friction-pyramid
  LCP (eqs. 3.6–3.7, the general fallback);
* :mod:`~pbr_xval.reference.lcp` — all solvers under one import.
* :mod:`~pbr_xval.reference.dense` — the small matrix products, least-squares solve and null
  space of the Python paths without BLAS or LAPACK (the same bits on every x86-64 CPU).

Deviations from the paper
-------------------------
This is the one place that lists them; each is also marked where it is implemented.

1. **Resting contact is not Baraff's Dantzig extended to 3-D.** The paper modifies Baraff's
   (1994) 2-D friction pivoting for 3-D; that algorithm is not published. Here the resting
   forces of eqs. 3.6–3.7 (exact circular cone, μ_s) come from an active-set solve
   (:func:`kernel.active_set_solve`: the previous step's free/stick/slide/impending-slip
   statuses — impending slip: static friction on the cone, its direction found by a Newton
   iteration so that it opposes the tangential acceleration — one equality solve, *verified*
   against every condition of eqs. 3.6–3.7, a few corrections);
   when no guess verifies, from an iterative cone solver (:func:`cone.solve_friction_cone`:
   Gauss–Seidel, then, from its 100th sweep, Newton on the contact modes it has found,
   verified against the same conditions) and, if that does not converge, a 16-facet friction-pyramid LCP solved by Lemke
   (:func:`cone.solve_friction_pyramid`). Failures of both are counted (``lcp_failures``).
2. **Sticking on three or more points is solved in the least-squares sense.** The centripetal
   part |ω|² r of the contact accelerations cannot be cancelled by any contact force when
   three or more non-collinear points stick (rigid Coulomb contact is inconsistent at that
   order); the minimum-norm least-squares forces are taken and the left-over acceleration is
   bounded by 2 |ω|² max |r| (zero at rest). Exact Coulomb solutions would need micro-slip
   with large internal tangential forces; it was this case that made the earlier cone
   iteration stall on a resting block.
3. **Impacts use a Coulomb cone with μ_s.** Eq. 3.5 has normal impulses only; a frictionless
   impulse would let a landing block slide. The impulses are solved with the cone (velocity
   form of eqs. 3.6–3.7, μ_s), which reproduces Housner's impact rule (ratio 0.850 for the
   project block), then the normal impulses are re-selected with the eq. 3.5 LCP, tangential
   impulses held fixed.
4. **Non-unique impact solutions are selected explicitly** (:mod:`selection`): the paper's
   Dantzig returns some vertex; here the solution closest to the previous step's impulses
   (``impact_selection = "closest_to_previous"``) or the minimum-norm one.
5. **Steps are accepted after the step-back limit.** The paper halves Δt "until no node of the
   rock penetrates more than ε". Here, after ``max_stepbacks`` halvings or below
   ``min_timestep``, the step is accepted with its penetration. This is a reported
   condition: the diagnostic ``min_timestep_hits`` counts such steps,
   ``accepted_penetration_max_m`` gives the deepest, and each (the first
   :data:`engine.MAX_ACCEPT_EVENTS` of a run) is a ``step_accepted_penetrating`` event
   with Δt, the penetration and ε.
6. **Velocity stabilisation.** Small residual normal velocities of resting contacts
   (approaching, or receding slower than ``separation_velocity``) and tangential velocities
   of sticking ones (left by the integration) are removed by a term v₀/Δt in the free
   acceleration b; zero in exact arithmetic. (Until 2026-11-28 only approaching normal
   velocities were: a receding resting contact then kept its velocity under its resting
   force, a rigid creep gravity never stopped; ``tests/reference/test_receding_contact.py``.)
7. **Thresholds the paper leaves open:** an in-band contact approaching faster than
   ``impact_velocity`` (1e-3 m/s) gets eq. 3.5 impulses; one sliding faster than
   ``slip_velocity`` (1e-4 m/s) gets dynamic friction μ_d; one separating faster than
   ``separation_velocity`` (1e-6 m/s) carries no resting force; the direct iteration stops at
   ``iteration_tol`` or after ``iterations`` (non-converged steps are counted).
8. **Contact nodes.** The contact set of a step is reduced to its support hull (exact: a node
   that is a convex combination of other contact nodes can carry no force that they cannot,
   see :mod:`kernel`); the rock's convex-hull vertices above its centre of mass are added to
   the basal nodes (``side_nodes``) so that a rock rotated far — lying on its side — still
   meets the pedestal (they cannot touch a flat pedestal before the rock tips past horizontal).
9. **Rest hold.** After the excitation has ended, a rock whose speed and velocity change per
   step are below ``rest_velocity`` is held (exact for a rigid rock on a rigid pedestal).
10. **Quasi-static hold during the excitation** (``static_hold``, default on; inertial ground
    motion). A rock at rest (the test of 9) whose in-band contact nodes span a polygon that
    holds the coming loads in static equilibrium — the line of action of g − a_g through the
    COM meets the pedestal inside the polygon, and g − a_g lies within the friction cone (μ_s),
    each within ``adapter.HOLD_MARGIN`` = 0.1 % of its limit; Housner's static uplift test with
    the vertical motion and friction included — stays at rest: its velocities are set to zero
    and the state held, not stepped, up to the first step whose load at either end the polygon
    cannot hold. Exact for the rigid model (rest is then a solution of eqs. 3.6–3.7); the
    stepped run differs from it by the round-off velocities it carries at rest, so a run near
    its toppling level can change outcome as under any round-off change.
"""
