"""MuJoCo's own cloth on the cloth's grid: a ``flexcomp`` membrane, NOT the same model as the
``cloth`` scene's springs (``cloth_flex``).

The grid, spacing, node masses, pins and gravity are the cloth's (same parameters, same
coordinates: every free node's position, row order); the force is MuJoCo's, not the springs':

* **Model**: ``<flexcomp type="grid" dim="2">``, m x n vertices of spacing s, vertex (column j,
  row i) at x = j s, y = -i s (the cloth's node (i, j)), ``mass`` spread equally over the n m
  vertices (a pinned vertex's share goes with it, as the cloth's pinned masses do), pins as
  ``<pin>``. Each grid square is two triangles (one diagonal: the membrane has no second shear
  direction and no bending; the cloth's shear and bending springs have no counterpart).
* **Force** (measured on mujoco 4.0.0, ``elastic2d="stretch"``): per triangle t the Saint
  Venant-Kirchhoff membrane written in squared edge lengths,
  E_t = 1/4 sum_{a,b} K_t[a, b] (l_a^2 - L_a^2)(l_b^2 - L_b^2) with K_t the 3 x 3 metric MuJoCo
  compiles from (young, poisson, thickness) into ``flex_stiffness``; the passive force is -grad E
  (checked against MuJoCo's ``qfrc_passive`` by central differences, tests/test_cloth_flex.py).
  ``mj_energyPos`` leaves this energy out (0 on a strained sheet), so ``energy`` computes it here
  from the state: kinetic + membrane + gravity (the cloth's height origin).
* **Membrane stiffness, chosen so**: poisson 0, thickness 1 (only young x thickness enters a
  membrane), and young such that the flex's highest frequency at the flat rest state equals the
  spring cloth's ``omega`` (sqrt(lambda_max(K)/m), K = -d(force)/dq). At rest both stiffness
  matrices are linear in their constants, so one probe at young = 1 fixes it. Then h*omega
  means the same on both scenes, and the stability limits compare.
* **omega**: sqrt(lambda_max(K_flex)/m) at the initial state, K_flex by central differences of
  MuJoCo's passive force (``hessian``).
* **Perturbing defaults, off**: contacts and self-collision (contype = conaffinity = 0,
  selfcollide none), edge stiffness and damping 0, edge equality constraints off, elasticity
  damping 0, bending off (elastic2d stretch); the adapter adds what every MuJoCo pose turns off
  (contact and constraint flags, autoreset) and records the compiled fields.
* **Reference**: MuJoCo's RK4 on this model, the step halved until two halvings agree
  (``scenarios/_model_reference.py``, as for a model file), over REFERENCE_PERIODS of the
  fastest mode; its estimated error is ``reference_error``. Errors and orders measured on this
  scene are against that run, never against the cloth's DOP853 reference.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import csr_matrix

from ._model_reference import RefinedRunReference
from .cloth import Cloth
from .scene import no_solve

#: The reference run spans this many periods of the fastest mode (2 pi / omega).
REFERENCE_PERIODS = 5.0
#: Central-difference step of the stiffness matrix, relative to the spacing (the membrane force
#: is a cubic polynomial of the positions, so the step's truncation error is ~1e-14 of it).
FD_STEP = 1e-6
#: What every output of this scene says it is not.
MODEL_NOTE = (
    "MuJoCo flexcomp membrane (StVK triangles): not the same model as the cloth's springs; "
    "errors and orders against its own refined RK4 run"
)


def no_accel(q, v, t, p):  # pragma: no cover - only reached by a misuse
    raise NotImplementedError("cloth_flex's force is MuJoCo's flex: no reference kernel steps it")


_FLEX = """<mujoco><option timestep="{dt!r}" integrator="{integrator}" gravity="0 0 {gz!r}">
<flag contact="disable" constraint="disable"{gravity_flag}/></option>
<worldbody><flexcomp name="cloth" type="grid" dim="2" count="{m} {n} 1" spacing="{s!r} {s!r} {s!r}"
 pos="{x0!r} {y0!r} 0" mass="{mass!r}" radius="{radius!r}">
<edge equality="false" stiffness="0" damping="0"/>
<contact contype="0" conaffinity="0" selfcollide="none"/>
<elasticity young="{young!r}" poisson="0" thickness="1" damping="0" elastic2d="stretch"/>
<pin id="{pins}"/>
</flexcomp></worldbody></mujoco>"""


class ClothFlex(RefinedRunReference, Cloth):
    id = "cloth_flex"
    title = (
        "MuJoCo flexcomp membrane on the cloth's grid (same n, m, s, mass, pins, g): NOT the same model as "
        "cloth's springs; reference: its own RK4, step halved until two halvings agree"
    )
    model_note = MODEL_NOTE
    has_kernels = False
    accel = staticmethod(no_accel)
    solve = staticmethod(no_solve)

    def __init__(self, **overrides):
        super().__init__(**overrides)
        self._m = None
        self._young = None
        self._flex_omega = None
        self.compile_warnings: list[str] = []

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_m"] = None  # a worker compiles the model again
        return state

    # ------------------------------------------------------------ the model
    def flex_xml(self, integrator: str = "Euler", dt: float = 1e-3, young: float | None = None) -> str:
        n, m, _ = self.grid
        s = self.values["s"]
        g = self.values["g"]
        cols = range(m) if self.values["pins"] == 1 else (0, m - 1)  # row 0: the whole edge, or its corners
        pins = " ".join(str(self.vertex(0, j)) for j in cols)
        return _FLEX.format(
            dt=float(dt),
            integrator=integrator,
            gz=-float(g),
            gravity_flag=' gravity="disable"' if g == 0 else "",
            m=m,
            n=n,
            s=float(s),
            x0=float((m - 1) * s / 2),
            y0=float(-(n - 1) * s / 2),
            mass=float(self.values["mass"]),
            radius=float(s / 100),
            young=float(self.young if young is None else young),
            pins=pins,
        )

    def vertex(self, i: int, j: int) -> int:
        """MuJoCo's vertex index of grid node (i, j): the grid counts x (columns) slowest and its y
        upwards, so row i is y index n - 1 - i."""
        n = self.grid[0]
        return j * n + (n - 1 - i)

    def engine_model(self, integrator: str = "Euler", dt: float = 1e-3, young: float | None = None):
        """A fresh compiled MuJoCo model (autoreset off), at this integrator and timestep. The
        compiler's warnings are collected into ``compile_warnings``, never printed or logged:
        mujoco 4.0.0 warns that the flex "is not rigid and has no equality constraints or passive
        forces", though its membrane force is on (``qfrc_passive``, tests/test_cloth_flex.py)."""
        import mujoco

        said: list[str] = []
        previous = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(said.append)
        try:
            m = mujoco.MjModel.from_xml_string(self.flex_xml(integrator, dt, young))
        finally:
            mujoco.set_mju_user_warning(previous)
        self.compile_warnings = sorted({" ".join(w.split()) for w in said})
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
        return m

    def _model(self):
        if self._m is None:
            self._m = self.engine_model()
            self._map = self._coordinate_map(self._m)
        return self._m

    def _coordinate_map(self, m):
        """(qpos index of each scene coordinate, the coordinate's rest value): node (i, j)'s
        vertex's body carries three slide joints along world x, y, z, its qpos the displacement
        from the body's rest position."""
        body = m.flex_vertbodyid[m.flex_vertadr[0] : m.flex_vertadr[0] + m.flex_vertnum[0]]
        index, rest = [], []
        for i, j in self.free_nodes():
            b = int(body[self.vertex(i, j)])
            for c in range(3):
                index.append(int(m.body_dofadr[b]) + c)
                rest.append(float(m.body_pos[b, c]))
        return np.array(index), np.array(rest)

    def engine_state(self, q, v):
        """The scene's (q, v) (positions, velocities) -> MuJoCo's (qpos, qvel)."""
        self._model()
        index, rest = self._map
        q, v = np.asarray(q, dtype=float), np.asarray(v, dtype=float)
        qpos, qvel = np.empty_like(q), np.empty_like(v)
        qpos[..., index] = q - rest
        qvel[..., index] = v
        return qpos, qvel

    def scene_state(self, qpos, qvel):
        """MuJoCo's (qpos, qvel) -> the scene's (q, v)."""
        self._model()
        index, rest = self._map
        return np.asarray(qpos)[..., index] + rest, np.asarray(qvel)[..., index].copy()

    @property
    def young(self) -> float:
        """The Young modulus (thickness 1) whose flex has the spring cloth's omega at rest."""
        if self._young is None:
            lam = self._lambda_max(self.engine_model(young=1.0))
            self._young = Cloth(**self.values).omega ** 2 * self.node_mass / lam
        return self._young

    # ------------------------------------------------------------ energy
    def _membrane(self):
        """(edge vertex pairs as grid node indices, rest lengths, per triangle its 3 edges and 3 x 3 metric)."""
        m = self._model()
        n, mm, _ = self.grid
        verts = m.flex_edge[m.flex_edgeadr[0] : m.flex_edgeadr[0] + m.flex_edgenum[0]]
        node = np.empty(n * mm, dtype=int)
        for i in range(n):
            for j in range(mm):
                node[self.vertex(i, j)] = i * mm + j
        ends = node[verts]
        rest = m.flexedge_length0[m.flex_edgeadr[0] : m.flex_edgeadr[0] + m.flex_edgenum[0]].copy()
        t = int(m.flex_elemnum[0])
        edges = m.flex_elemedge[m.flex_elemedgeadr[0] : m.flex_elemedgeadr[0] + 3 * t].reshape(t, 3)
        packed = m.flex_stiffness[m.flex_stiffnessadr[0] : m.flex_stiffnessadr[0] + 21 * t].reshape(t, 21)[:, :6]
        metric = np.empty((t, 3, 3))
        k = 0
        for a in range(3):
            for b in range(a, 3):
                metric[:, a, b] = metric[:, b, a] = packed[:, k]
                k += 1
        return ends, rest, edges, metric

    def membrane_energy(self, q) -> np.ndarray:
        """The flex's elastic energy at positions q (API layout) -> (...)."""
        ends, rest, edges, metric = self._membrane()
        x = self.positions(q)
        length2 = np.sum((x[..., ends[:, 1], :] - x[..., ends[:, 0], :]) ** 2, axis=-1)
        strain = (length2 - rest * rest)[..., edges]  # (..., T, 3)
        return 0.25 * np.einsum("...ta,tab,...tb->...", strain, metric, strain)

    def energy(self, q, v):
        n, _, d = self.grid
        q, v = np.asarray(q, dtype=float), np.asarray(v, dtype=float)
        height = q[..., d - 1 :: d] + (n - 1) * self.values["s"]
        mass = self.node_mass
        return (
            0.5 * mass * np.sum(v * v, axis=-1)
            + self.membrane_energy(q)
            + mass * self.values["g"] * np.sum(height, axis=-1)
        )

    # ------------------------------------------------------------ stiffness and omega
    def _force_jacobian(self, m, q) -> np.ndarray:
        """-d(passive force)/dq at the scene state q, in the scene's coordinates, by central differences."""
        import mujoco

        d = mujoco.MjData(m)
        index, rest = self._coordinate_map(m)
        qpos = np.zeros(m.nq)
        qpos[index] = np.asarray(q, dtype=float) - rest
        h = FD_STEP * self.values["s"]
        size = len(index)
        K = np.empty((size, size))
        for c in range(size):
            f = []
            for sign in (1.0, -1.0):
                d.qpos[:] = qpos
                d.qpos[index[c]] += sign * h
                mujoco.mj_forward(m, d)
                f.append(d.qfrc_passive[index].copy())
            K[:, c] = -(f[0] - f[1]) / (2 * h)
        return 0.5 * (K + K.T)

    def _lambda_max(self, m) -> float:
        return float(np.linalg.eigvalsh(self._force_jacobian(m, self.initial_state()[0]))[-1])

    def hessian(self, q):
        """The flex's stiffness matrix -d(force)/dq at the state q (MuJoCo's passive force, central
        differences), sparse like the cloth's."""
        return csr_matrix(self._force_jacobian(self._model(), np.asarray(q, dtype=float)))

    @property
    def omega(self):
        if self._flex_omega is None:
            self._flex_omega = self.omega_max_at(self.initial_state()[0])
        return self._flex_omega

    # ------------------------------------------------------------ reference
    @property
    def reference_horizon(self) -> float:
        return REFERENCE_PERIODS * 2.0 * math.pi / self.omega

    def describe(self) -> dict:
        out = super().describe()
        out.update(
            young=self.young,
            poisson=0.0,
            thickness=1.0,
            elastic2d="stretch",
            young_rule="young such that the flex's omega_max at rest equals the spring cloth's",
        )
        return out
