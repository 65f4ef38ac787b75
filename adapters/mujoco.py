"""MuJoCo: one method per integrator (``mujoco:euler``, ``rk4``, ``implicit``, ``implicitfast``,
``discrete``) on the spring, the damped spring, the pendulum and the projectile.

Minimal models (measured semantics in ENGINES.md): one body with the scene's exact mass on
slide joints along world axes (spring and drag as joint stiffness and damping), or on a hinge
with a point mass for the pendulum; contacts and constraints off, gravity only where the
scene has it, armature 0. Autoreset is disabled and every bad-state warning ends the run as
``unstable`` at that step: MuJoCo otherwise silently resets a diverged state to the initial
one, and a blow-up would look like a calm spring. Warnings go to a handler, not to stdout or
MUJOCO_LOG.TXT.
"""
from __future__ import annotations

import numpy as np

from scenarios import Scene

from ._base import EngineMode

#: Our mode name -> MuJoCo's integrator name in MJCF.
INTEGRATORS = {"euler": "Euler", "rk4": "RK4", "implicit": "implicit", "implicitfast": "implicitfast",
               "discrete": "discrete"}

SCENES = ("spring", "damped_spring", "pendulum", "projectile")
UNSUPPORTED = {
    "kepler": "MuJoCo has no central 1/r^2 force (an mjcb_passive callback would be our force, not MuJoCo's)",
}

#: Divergence warnings. MuJoCo raises them when a qpos/qvel/qacc entry is NaN, inf or
#: larger than 1e10 (mjMAXVAL), so an engine run may stop earlier than a reference one.
_BAD_STATE = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")

_OPTION = '<option timestep="{dt!r}" integrator="{integrator}" gravity="0 0 {gz!r}">' \
          '<flag contact="disable" constraint="disable"{gravity_flag}/></option>'

_SLIDES = """<mujoco>{option}<worldbody><body name="mass">
  <inertial pos="0 0 0" mass="{m!r}" diaginertia="1 1 1"/>
  {joints}
</body></worldbody></mujoco>"""

_SLIDE = ('<joint name="{name}" type="slide" axis="{axis}" stiffness="{k!r}" springref="0" '
          'damping="{c!r}" armature="0"/>')

# MuJoCo rejects a principal inertia below 1e-15 at compile time; it is zeroed after
# compiling so that the joint mass is exactly m L^2 (a point mass).
_PENDULUM = """<mujoco>{option}<worldbody><body name="bob">
  <joint name="theta" type="hinge" axis="0 1 0" pos="0 0 0" stiffness="0" damping="0" armature="0"/>
  <inertial pos="0 0 {z!r}" mass="{m!r}" diaginertia="1e-15 1e-15 1e-15"/>
</body></worldbody></mujoco>"""


def _xml(integrator: str, scene: Scene, dt: float) -> str:
    p = scene.values
    if scene.id == "pendulum":
        option = _OPTION.format(dt=dt, integrator=integrator, gz=-p["g"], gravity_flag="")
        return _PENDULUM.format(option=option, z=-p["L"], m=p["m"])
    if scene.id == "projectile":
        option = _OPTION.format(dt=dt, integrator=integrator, gz=-p["g"], gravity_flag="")
        # The scene's (x, y) with y up are MuJoCo's x and z (gravity along -z); drag is joint damping.
        joints = "\n  ".join(_SLIDE.format(name=n, axis=a, k=0.0, c=p["c"])
                             for n, a in (("x", "1 0 0"), ("y", "0 0 1")))
        return _SLIDES.format(option=option, m=p["m"], joints=joints)
    option = _OPTION.format(dt=dt, integrator=integrator, gz=0.0, gravity_flag=' gravity="disable"')
    joints = _SLIDE.format(name="x", axis="1 0 0", k=p["k"], c=p.get("c", 0.0))
    return _SLIDES.format(option=option, m=p["m"], joints=joints)


class _Model:
    def __init__(self, mujoco, mode: str, scene: Scene, dt: float):
        self.mj = mujoco
        self.m = m = mujoco.MjModel.from_xml_string(_xml(INTEGRATORS[mode], scene, dt))
        if scene.id == "pendulum":
            m.body_inertia[1] = 0.0
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
        self.d = d = mujoco.MjData(m)
        q0, v0 = scene.initial_state()
        d.qpos[:] = q0
        d.qvel[:] = v0
        self._bad = [int(getattr(mujoco.mjtWarning, w)) for w in _BAD_STATE]
        self._counts = self._bad_counts()
        mujoco.mj_forward(m, d)
        full = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, full)
        disabled = [name for name, bit in mujoco.mjtDisableBit.__members__.items()
                    if name != "mjNDISABLE" and m.opt.disableflags & int(bit)]
        self.settings = {
            "integrator": mujoco.mjtIntegrator(m.opt.integrator).name,
            "timestep": float(m.opt.timestep),
            "gravity": [float(x) for x in m.opt.gravity],
            "disabled": disabled,
            "eulerdamp": "mjDSBL_EULERDAMP" not in disabled,
            "autoreset": "mjDSBL_AUTORESET" not in disabled,
            "tolerance": float(m.opt.tolerance),
            "iterations": int(m.opt.iterations),
            "mass_matrix_diagonal": [float(x) for x in np.diag(full)],
            "joint_stiffness": [float(x) for x in m.jnt_stiffness],
            "joint_damping": [float(x) for x in m.dof_damping],
            "armature": [float(x) for x in m.dof_armature],
            "ngeom": int(m.ngeom),
        }
        # Last, so that nothing can fail between installing the handler and close() restoring it.
        self.warnings: list[str] = []
        self._previous_handler = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(self.warnings.append)

    def _bad_counts(self) -> list[int]:
        return [int(self.d.warning[i].number) for i in self._bad]

    def advance(self) -> None:
        self.mj.mj_step(self.m, self.d)

    def state(self):
        return self.d.qpos.copy(), self.d.qvel.copy()

    def trouble(self) -> str | None:
        counts = self._bad_counts()
        if counts == self._counts:
            return None
        self._counts = counts
        said = self.warnings[-1] if self.warnings else "bad state"
        return f"MuJoCo warned: {said.strip()}"

    def close(self) -> None:
        self.mj.set_mju_user_warning(self._previous_handler)


def build(mujoco, mode: str, scene: Scene, dt: float) -> _Model:
    return _Model(mujoco, mode, scene, dt)


_DOCS = {
    "euler": """semi-implicit Euler (velocity first); joint damping implicit (eulerdamp)
        Measured: equals ref:semi_implicit_euler bitwise on the spring; with damping c it is
        v += h(-k x - c v)/(m + h c), x += h v.""",
    "rk4": """classical RK4
        Measured: equals ref:rk4 to ~1e-14 on the spring.""",
    "implicit": """semi-implicit Euler, implicit in velocity-dependent forces only
        Measured: equals ref:semi_implicit_euler bitwise on the undamped spring (the spring
        force stays explicit); with damping the same update as mujoco:euler.""",
    "implicitfast": """semi-implicit Euler, implicit in velocity-dependent forces only (no Coriolis terms)
        Measured: as mujoco:implicit on these scenes.""",
    "discrete": """backward (implicit) Euler: solves (M + hD + h^2 K) a = f - h K v
        Measured: equals ref:implicit_euler to ~1e-14 on the spring; gravity stays explicit.""",
}

METHODS = {
    f"mujoco:{mode}": EngineMode(
        engine="mujoco", mode=mode, module="mujoco", dist="mujoco", build=build,
        scenes=SCENES, unsupported=UNSUPPORTED, doc=_DOCS[mode],
        settings={"integrator": name, "autoreset": "disabled", "contact": "disabled",
                  "constraint": "disabled", "gravity": "scene's g along -z, else disabled",
                  "armature": 0, "warnings": "collected, never printed or logged"},
    )
    for mode, name in INTEGRATORS.items()
}
