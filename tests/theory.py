"""What the measurements must reproduce, and the tolerance each is held to, with where each
number comes from: one table for tests/test_measure.py and tests/test_measure_engines.py.

Sources: issue 4 ("Tests that must hold") and the theory section of docs/engines.md (unit
spring, omega = 1).

The table is the independent oracle: written from the textbooks, apart from what each scheme
declares or derives of itself (a splitting's or a tableau's limit, a substepped scheme's n times its
scheme's), so a derivation that goes wrong fails here. A new scheme therefore adds its line here,
to ``REF_ORDER`` and ``REF_STABILITY`` at least (tests/test_measure.py fails until every
unconstrained scheme has both), and where it is measured there, to ``REF_ENERGY`` and ``REF_EVALS``
(docs/contributing.md, "A scheme"). The other inventories of the schemes are read from the
registry (``reference.METHODS``).
"""

import math

SQRT8 = 2.0 * math.sqrt(2.0)
UNBOUNDED, UNSTABLE, UNRESOLVED = "unbounded", "unstable", "unresolved"

#: Largest stable h*omega on `spring`, "within 0.5%" (issue 4). Theory: the stability
#: polynomials on the imaginary axis (docs/engines.md): 2 for the one-evaluation symplectic
#: schemes, 2 sqrt(2) for RK4, 1.5734 for Forest-Ruth.
STABILITY_RTOL = 0.005
REF_STABILITY = {
    "explicit_euler": UNSTABLE,
    "semi_implicit_euler": 2.0,
    "semi_implicit_euler_position_first": 2.0,
    "verlet": 2.0,
    "velocity_verlet": 2.0,
    "leapfrog": 2.0,
    "rk4": SQRT8,
    "forest_ruth": 1.5734,
    "implicit_euler": UNBOUNDED,
    "implicit_midpoint": UNBOUNDED,
    # Without damping (the spring) the damping schemes are semi-implicit Euler's two forms.
    "semi_implicit_euler_velocity_implicit": 2.0,
    "position_first_euler_decay_after_kick": 2.0,
    "position_first_euler_decay_before_kick": 2.0,
    # On a linear scene backward Euler itself (to roundoff): never unstable.
    "linearly_implicit_euler": UNBOUNDED,
    # The tableaus' stability polynomials (tests/test_tableau.py derives each): Heun 1 + y^4/4 > 1;
    # every three-stage third-order scheme sqrt(3); Dormand-Prince 5's fifth-order solution 0.99719.
    # Heun's |R(i y)| - 1 = y^4/8 > 0 at every y, below the measure's RHO_TOL (1e-12) up to
    # y = (8e-12)^(1/4) = 0.00168: no stable step resolved, never a limit of 0.00168.
    "heun": UNRESOLVED,
    "kutta_rk3": math.sqrt(3.0),
    "bogacki_shampine3": math.sqrt(3.0),
    "dormand_prince5": 0.99719,
    # Two implicit Euler half steps: 1/(1 + y^2/4)^2 per step, never unstable.
    "implicit_euler_doubled": UNBOUNDED,
    # Two-stage Radau IIA is L-stable; PBD and XPBD on one linear spring are implicit Euler.
    "radau_iia2": UNBOUNDED,
    "pbd": UNBOUNDED,
    "xpbd": UNBOUNDED,
    "xpbd_jacobi": UNBOUNDED,
}
ENGINE_STABILITY = {
    "mujoco:euler": 2.0,
    "mujoco:implicit": 2.0,
    "mujoco:implicitfast": 2.0,
    "pybullet:semi_implicit": 2.0,
    "mujoco:rk4": SQRT8,
    "mujoco:discrete": UNBOUNDED,
}

#: Observed order "within +-0.15 of theory" (issue 4), on spring, pendulum and kepler.
ORDER_TOL = 0.15
ORDER_SCENES = ("spring", "pendulum", "kepler")
#: Where a scheme's measured slope is still pre-asymptotic within the measure's error range, the
#: wider tolerance and why. Dormand-Prince 5 on the pendulum: local slopes 5.07 (errors 3e-11 to
#: 1.3e-10) rising to 5.57 (7e-8 to 3e-7), the h^6 term not yet negligible at the larger steps;
#: the fit over them gives 5.24.
ORDER_TOL_FOR = {("dormand_prince5", "pendulum"): 0.3}
REF_ORDER = {
    "explicit_euler": 1,
    "semi_implicit_euler": 1,
    "semi_implicit_euler_position_first": 1,
    "verlet": 2,  # the reported velocity (x_n - x_{n-1})/h + h a_n/2 is second order too
    "velocity_verlet": 2,
    "leapfrog": 2,
    "rk4": 4,
    "implicit_euler": 1,
    "implicit_midpoint": 2,
    "forest_ruth": 4,
    "semi_implicit_euler_velocity_implicit": 1,
    "position_first_euler_decay_after_kick": 1,
    "position_first_euler_decay_before_kick": 1,
    "linearly_implicit_euler": 1,
    "heun": 2,
    "kutta_rk3": 3,
    "bogacki_shampine3": 3,
    "dormand_prince5": 5,
    "implicit_euler_doubled": 1,
    "radau_iia2": 3,
    "pbd": 1,
    "xpbd": 1,
    "xpbd_jacobi": 1,
}
#: (method, scene) -> order. The engines' scenes: the spring for MuJoCo and pybullet,
#: the Kepler orbit for REBOUND's leapfrog (docs/engines.md: 2nd order on it).
ENGINE_ORDER = {
    ("mujoco:euler", "spring"): 1,
    ("mujoco:rk4", "spring"): 4,
    ("pybullet:semi_implicit", "spring"): 1,
    ("rebound:leapfrog", "kepler"): 2,
}

#: Energy classification on `spring` at h = 0.1 (issue 4, the seed's table), over 10^4
#: steps (159 periods: every tenth holds 16 periods, as the rule wants).
ENERGY_DT = 0.1
ENERGY_STEPS = 10_000
REF_ENERGY = {
    "explicit_euler": "grows",
    "semi_implicit_euler": "bounded",
    "semi_implicit_euler_position_first": "bounded",
    "verlet": "bounded",
    "velocity_verlet": "bounded",
    "leapfrog": "bounded",
    "rk4": "decays",
    "implicit_euler": "decays",
    "linearly_implicit_euler": "decays",
    "heun": "grows",
    "kutta_rk3": "decays",
    "bogacki_shampine3": "decays",
    "implicit_euler_doubled": "decays",
    "radau_iia2": "decays",
    "pbd": "decays",
    "xpbd": "decays",
    "xpbd_jacobi": "decays",
}

#: Counted (force evaluations, solves) per step on the spring (issue 4: "1, 1, 1, 4,
#: 1 (+ solve)"); a linear scene needs one Newton iteration, so one solve.
REF_EVALS = {
    "explicit_euler": (1, 0),
    "semi_implicit_euler": (1, 0),
    "verlet": (1, 0),
    "rk4": (4, 0),
    "implicit_euler": (1, 1),
    "linearly_implicit_euler": (1, 1),
    "heun": (2, 0),
    "kutta_rk3": (3, 0),
    "bogacki_shampine3": (3, 0),
    "dormand_prince5": (6, 0),
    "implicit_euler_doubled": (2, 2),
}
