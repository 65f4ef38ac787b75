"""Which scenes each pymunk mode poses, and why not the others (``adapters.pymunk``'s modes):
the reasons ``harness list`` and every refusal print."""

_FORCE_SCENES = ("spring", "damped_spring", "projectile", "chain")
_SHEET = "Chipmunk is 2-D: the cloth is posed in its plane as the scene net (pymunk:damped_spring)"
_NET = "the net's springs as Chipmunk's own DampedSprings: see pymunk:damped_spring"
_FORCE_UNSUPPORTED = {"cloth": _SHEET, "net": _NET,
    "pendulum": "a pendulum in Chipmunk is a joint, not a force: see pymunk:pin_joint",
    "rope": "a rope in Chipmunk is pin joints, not forces: see pymunk:pin_joint",
    "kepler": "not posed: Chipmunk has no gravity between bodies, and a 1/r^2 force from Python would only "
              "repeat what the spring shows (same force path, same scheme); Kepler is REBOUND's scene",
}
_PINS = "pin joints pose only the pendulum and the rope"
_JOINT_UNSUPPORTED = {"kepler": _PINS, "cloth": _SHEET, "net": _NET,
                      **{scene: f"{_PINS}; see pymunk:{mode}" for scene, mode in (
    ("spring", "spring_force"), ("damped_spring", "spring_force"), ("projectile", "applied_force"),
    ("chain", "damped_spring"))}}
_SPRING_UNSUPPORTED = {"cloth": _SHEET,
    "spring": "not posed: a DampedSpring to a static body integrates the 1-DOF spring as pymunk:spring_force "
              "does (position-first semi-implicit Euler, 5e-14 in docs/engines.md); Chipmunk's springs link bodies "
              "on the chain, and damp on the damped spring",
    "pendulum": "a pendulum in Chipmunk is a joint: see pymunk:pin_joint",
    "rope": "a rope in Chipmunk is pin joints: see pymunk:pin_joint",
    "projectile": "no spring in the projectile: see pymunk:applied_force",
    "kepler": "no spring in the Kepler problem",
}

_SPACE_DAMPING_SCENES = ("damped_spring", "projectile")
_SPACE_DAMPING_UNSUPPORTED = {"cloth": _SHEET, "net": "no damping in the net",
    "spring": "no damping to give space.damping: see pymunk:spring_force",
    "chain": "the chain's damping acts between neighbours; space.damping damps each body against the world",
    **{scene: f"no damping in the {name}" for scene, name in (
        ("pendulum", "pendulum"), ("rope", "rope"), ("kepler", "Kepler problem"))},
}
