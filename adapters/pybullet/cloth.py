"""pybullet's model of the cloth: Bullet's deformable world (``RESET_USE_DEFORMABLE_WORLD``) with one
mass-spring soft body (``loadSoftBody(useMassSpring=1)``) on the scene's grid, written as a
triangle mesh, the pinned nodes anchored to the world.

What Bullet builds (btSoftBodyHelpers::CreateFromTriMesh, btDeformableMassSpringForce; pybullet
3.2.7), and how the pose makes it the scene's cloth exactly:

* one spring (a "link") per distinct triangle edge, every one at ``springElasticStiffness``, rest
  length the edge's length when the body is placed. A square split along (i, j)-(i+1, j+1) gives
  the structural springs and that one diagonal: the scene with ``shear`` = 1 and k_shear = k. The
  bending springs (``generateBendingConstraints(2)``) join every pair of nodes two links apart:
  besides the scene's (0, 2), (2, 0) and second diagonal they make (1, 2), (2, 1) and (2, 2)
  links, which the scene has not, so they are off and k_bend must be 0 (``refusal``);
* Bullet's OBJ reader parses vertices as float32: the mesh holds the integer grid coordinates
  (exact in float32) and ``scale`` = s places node (i, j) at (j s, -i s, 0), the scene's start
  bit for bit; the rest lengths are then taken from those positions in double precision;
* the total mass is shared equally (``setTotalMass``: every node mass/(n m)); an anchor to the
  world (``createSoftBodyAnchor`` with body -1) sets its node's mass to 0: the node never moves;
* gravity is a force of the body, a copy of the world's gravity when the body is loaded.

The deformable solver is called implicit, but in pybullet it is not: pybullet builds the world
with implicit off (``m_implicit`` false, no switch in its API), so the elastic forces are applied
explicitly, v* = v + h f(x)/m, and only the springs' damping enters the conjugate-residual solve
(M - h D) dv = h f_damp(v*). With the damping at 0 that solve has a zero right-hand side, and
x += h v: semi-implicit Euler, measured to roundoff against ``ref:semi_implicit_euler``.

pybullet reads and sets node positions only (``getMeshData`` / ``resetMeshData``; the node
velocity is in the C API alone), so the velocity reported is (x_n - x_{n-1}) / h, the positions
before and after the last step: Bullet's update x_n = x_{n-1} + h v_n read backwards, v_n to a
roundoff of |x| eps / h. The model starts where the scene starts (at rest, flat): a soft body
takes its rest lengths from the nodes' positions at its first step (``updateConstants``), and
no node velocity can be given, so another start is refused.
"""

from __future__ import annotations

import os
import tempfile

import numpy as np

from scenarios import Scene

from .._model import SteppedModel

#: loadSoftBody's arguments beside the scene's mass, stiffness and spacing: every force but the
#: springs' elasticity off. springBendingStiffness must be 0 itself: pybullet always passes it
#: (default 0.1), and a non-zero one builds the bending links whatever useBendingSprings says
#: (measured: 7.5e-3 apart over 1000 steps on the 4 x 4 sheet at k = 1000); springDampingStiffness
#: defaults to 0.1 (4.2e-3 apart there, 0.9% of the energy gone in 1 s).
LOAD = {
    "useMassSpring": 1,
    "useBendingSprings": 0,
    "springBendingStiffness": 0.0,
    "springDampingStiffness": 0.0,
    "springDampingAllDirections": 0,
    "useNeoHookean": 0,
    "useSelfCollision": 0,
    "useFaceContact": 0,
    "frictionCoeff": 0.0,
}

#: btSoftBodyWorldInfo's m_maxDisplacement: after the solve, each velocity component is clamped
#: to it / dt. A blow-up then stays finite: measured on the 4 x 4 sheet at h omega = 3 and 100, it
#: grows to |x| ~ 700 in 20 steps and stays there, the nodes jumping 1000 a step, its energy 1e10
#: times the start, never the non-finite state the harness's divergence test waits for. A step
#: that moved a node this far is the engine's own blow-up (``trouble``).
MAX_DISPLACEMENT = 1000.0

#: What cannot be set from pybullet, and why it does not act here (recorded with every run).
KEPT = {
    "collisionMargin": "0.02, Bullet's (loadSoftBody ignores a margin <= 0): one body, self-collision off, nothing to "
    "collide with; it widens the bounding box of the clamp below",
    "repulsionStiffness": "0.5, Bullet's (ignored unless > 0): acts on self-collision contacts only, which are off",
    "velocity_clamps": "|v| <= the body's bounding-box diagonal / dt before the position update, and each component "
    "<= 1000 / dt after it (m_maxDisplacement): not settable, reached only by a blow-up, which "
    "they hold finite; a node moved 1000 in one step ends the run as unstable",
    "implicit": "off (pybullet builds the deformable world with m_implicit false): only spring damping, here 0, "
    "is solved for",
}


def refusal(scene: Scene) -> str | None:
    """Why Bullet's soft body cannot pose this cloth (None: it can): its springs are the mesh's
    triangle edges at one stiffness, and no bending springs (module docstring)."""
    v = scene.values
    bad = [
        name
        for name, ok in (
            ("shear", v["shear"] == 1),
            ("k_shear", v["k_shear"] == v["k"]),
            ("k_bend", v["k_bend"] == 0.0),
        )
        if not ok
    ]
    if not bad:
        return None
    got = ", ".join(f"{name}={v[name]:g}" for name in bad)
    return (
        f"Bullet's mass-spring soft body poses the triangulated cloth only, shear=1, k_shear=k, k_bend=0 "
        f"(got {got}): its springs are a triangle mesh's edges at one stiffness, and its bending springs add "
        f"(1, 2), (2, 1) and (2, 2) links the scene has not"
    )


def grid_mesh(n: int, m: int) -> str:
    """The OBJ of an n x m grid: node (i, j) is vertex i m + j at (j, -i, 0); each square two
    triangles split along (i, j)-(i+1, j+1)."""
    lines = [f"v {j} {-i} 0" for i in range(n) for j in range(m)]
    for i in range(n - 1):
        for j in range(m - 1):
            a = i * m + j + 1  # OBJ counts from 1
            lines += [f"f {a} {a + m} {a + m + 1}", f"f {a} {a + m + 1} {a + 1}"]
    return "\n".join(lines) + "\n"


def mesh_edges(n: int, m: int) -> set[tuple[int, int]]:
    """The distinct edges of ``grid_mesh``'s triangles (node pairs, smaller first): Bullet's links."""
    edges = set()
    for line in grid_mesh(n, m).splitlines():
        if line.startswith("f "):
            a, b, c = (int(x) - 1 for x in line.split()[1:])
            edges |= {tuple(sorted(e)) for e in ((a, b), (b, c), (c, a))}
    return edges


class SoftBodyCloth(SteppedModel):
    """The cloth as one mass-spring soft body (module docstring); state: the free nodes' positions
    in row order, and their velocities from the last step's displacement."""

    FORCE = "Bullet's own: btDeformableMassSpringForce on the mesh's edges and btDeformableGravityForce"
    ENGINE_LOOP = (
        "stepSimulation only, the node positions read before the last step of each output interval "
        "and after it (the velocity is their difference / dt)"
    )

    def __init__(self, p, scene: Scene, dt: float):
        why = refusal(scene)
        if why:
            raise ValueError(f"pybullet: {why}")
        q0, v0 = scene.initial_state()
        n, m, _ = scene.grid
        self.free = np.array([i * m + j for i, j in scene.free_nodes()], dtype=int)
        start = scene.rest_positions()[self.free].ravel()
        if not (np.array_equal(q0, start) and not np.any(v0)):
            raise ValueError(
                "pybullet: a soft body starts at its mesh, at rest (it takes its rest lengths from the "
                "nodes' positions at its first step, and pybullet sets no node velocity)"
            )
        self.p, self.dt, self.v0 = p, dt, v0.copy()
        self.cid = cid = p.connect(p.DIRECT)
        values = scene.values
        p.resetSimulation(p.RESET_USE_DEFORMABLE_WORLD, physicsClientId=cid)
        p.setPhysicsEngineParameter(fixedTimeStep=dt, numSubSteps=0, physicsClientId=cid)
        p.setGravity(0.0, 0.0, -values["g"], physicsClientId=cid)  # before loading: the body copies it
        fd, path = tempfile.mkstemp(prefix="cloth-", suffix=".obj")
        try:
            with os.fdopen(fd, "w") as f:
                f.write(grid_mesh(n, m))
            self.body = b = p.loadSoftBody(
                path,
                scale=values["s"],
                mass=values["mass"],
                springElasticStiffness=values["k"],
                physicsClientId=cid,
                **LOAD,
            )
        finally:
            os.remove(path)
        p.changeDynamics(b, -1, activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=cid)
        free = set(self.free.tolist())
        pinned = [node for node in range(n * m) if node not in free]
        for node in pinned:
            p.createSoftBodyAnchor(b, node, -1, -1, physicsClientId=cid)
        self.before = self.after = None
        nodes = self._positions()
        engine = p.getPhysicsEngineParameters(physicsClientId=cid)
        self.settings = {
            "world": "deformable (RESET_USE_DEFORMABLE_WORLD)",
            "fixedTimeStep": float(engine["fixedTimeStep"]),
            "numSubSteps": int(engine["numSubSteps"]),
            "gravity": [
                float(engine["gravityAccelerationX"]),
                float(engine["gravityAccelerationY"]),
                float(engine["gravityAccelerationZ"]),
            ],
            "mesh": f"{n} x {m} grid, integer coordinates, two triangles a square split along (i, j)-(i+1, j+1), "
            f"scale = s",
            "nodes": len(nodes),
            "nodes_at_scene_start": bool(np.array_equal(nodes[self.free].ravel(), start)),
            "springs": f"{len(mesh_edges(n, m))}: the mesh's distinct triangle edges",
            "springElasticStiffness": float(values["k"]),
            "mass": f"{values['mass']!r} in all, equal per node (setTotalMass)",
            "anchors": f"{len(pinned)} to the world (createSoftBodyAnchor, body -1: the node's mass 0)",
            **LOAD,
            "sleeping": "disabled (a sheet slower than 0.04 for 2 s is frozen otherwise: 0.10 off at g = 0.01)",
            **KEPT,
            "velocity": "(x_n - x_{n-1}) / dt: pybullet reads no node velocity",
            "force": self.FORCE,
            "engine_loop": self.ENGINE_LOOP,
        }

    def _positions(self) -> np.ndarray:
        p = self.p
        return np.array(p.getMeshData(self.body, flags=p.MESH_DATA_SIMULATION_MESH, physicsClientId=self.cid)[1])

    def advance(self) -> None:
        self.before = self._positions()
        self.p.stepSimulation(physicsClientId=self.cid)

    def steps(self, n: int) -> None:
        step, cid = self.p.stepSimulation, self.cid
        for _ in range(n - 1):
            step(physicsClientId=cid)
        if n > 0:
            self.advance()

    def state(self):
        self.after = x = self._positions()
        q = x[self.free].ravel()
        if self.before is None:
            return q, self.v0.copy()
        return q, ((x - self.before) / self.dt)[self.free].ravel()

    def trouble(self) -> str | None:
        """The velocity clamp at work (``MAX_DISPLACEMENT``), seen in the last step read by ``state``."""
        if self.before is None or self.after is None:
            return None
        jump = float(np.max(np.abs(self.after - self.before), initial=0.0))
        if not jump >= MAX_DISPLACEMENT * (1.0 - 1e-9):
            return None
        return (
            f"Bullet clamped a node's velocity to m_maxDisplacement / dt (it moved {jump:.6g} in one step): the "
            f"sheet blew up and Bullet holds it finite"
        )

    def evaluations(self):
        return None, "Bullet evaluates its forces inside stepSimulation and has no counter or callback for them"

    def close(self) -> None:
        self.p.disconnect(physicsClientId=self.cid)
