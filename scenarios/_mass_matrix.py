"""How much a MuJoCo model's mass matrix M(q) changes over a set of configurations.

MuJoCo's Euler (and implicit, implicitfast; pybullet's semi-implicit step) updates the
generalized *velocity*: ``v+ = v + h M(q)^-1 f(q, v)``, ``q+ = q + h v+``. With M constant that
map is symplectic Euler in (q, p = M v) and keeps a bounded energy error; where M depends on q it
is not symplectic (its Jacobian in (q, p) has a determinant other than 1) and the energy can
drift (docs/findings.md). Whether a model is of the second kind is this module's one number:

    variation = max over q of max |eig(M(q0)^-1 M(q)) - 1|

q0 the first configuration: the largest relative change, over the configurations, of the kinetic
energy 1/2 v'M v of any one velocity v. It does not depend on the units of the coordinates
(a slide in metres beside a hinge in radians), and is 0 to roundoff for a model whose M is
constant (slides, a single hinge).
"""

from __future__ import annotations

import numpy as np

#: The most configurations compared (evenly spaced over those given): M and one small
#: generalized eigenproblem per configuration.
MAX_CONFIGURATIONS = 200


def mass_matrix(m, d, qpos) -> np.ndarray:
    """The dense mass matrix (nv, nv) of MuJoCo model ``m`` at ``qpos`` (``d``: its MjData, overwritten)."""
    import mujoco

    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    mujoco.mj_crb(m, d)
    if hasattr(mujoco, "mj_makeM"):  # where mj_crb leaves the inertia matrix to mj_makeM (3.3.7)
        mujoco.mj_makeM(m, d)
    return full_mass_matrix(mujoco, m, d)


def full_mass_matrix(mj, m, d) -> np.ndarray:
    """The dense mass matrix at ``d``'s computed state (after ``mj_forward`` or ``mj_crb``). The
    binding takes ``(m, d, dst)`` in newer MuJoCo releases and ``(m, dst, M)`` with the sparse
    ``d.qM`` in older ones (3.3.7 and before): asked of the binding's signature, not the version."""
    full = np.zeros((m.nv, m.nv))
    head = (mj.mj_fullM.__doc__ or "").split("(", 1)[-1].split(")", 1)[0]
    names = [part.split(":")[0].strip() for part in head.split(",")]
    if names[1:2] == ["d"]:
        mj.mj_fullM(m, d, full)
    else:
        mj.mj_fullM(m, full, d.qM)
    return full


def kinetic_change(m0: np.ndarray, m1: np.ndarray) -> float:
    """max |eig(m0^-1 m1) - 1|: the largest relative change of v'M v from ``m0`` to ``m1``."""
    from scipy.linalg import eigh

    lam = eigh(m1, m0, eigvals_only=True)
    return float(np.max(np.abs(lam - 1.0)))


def model_mass_matrix_variation(m, qpos_rows) -> float | None:
    """``variation`` (module docstring) of MuJoCo model ``m`` over the configurations ``qpos_rows``
    (rows of qpos; rows that are not finite are left out). None where fewer than two remain."""
    import mujoco

    q = np.asarray(qpos_rows, dtype=float).reshape(-1, m.nq)
    q = q[np.all(np.isfinite(q), axis=1)]
    if len(q) < 2 or m.nv == 0:
        return None
    if len(q) > MAX_CONFIGURATIONS:
        q = q[np.unique(np.linspace(0, len(q) - 1, MAX_CONFIGURATIONS).astype(int))]
    d = mujoco.MjData(m)
    m0 = mass_matrix(m, d, q[0])
    return max(kinetic_change(m0, mass_matrix(m, d, row)) for row in q[1:])


def mass_matrix_variation(scene, q) -> float | None:
    """``Scene.mass_matrix_variation`` for a scene whose coordinates are MuJoCo's qpos and whose
    model is ``scene.engine_model()`` (a model file, ``scenarios.model.ModelScene``): the variation
    of its mass matrix over the configurations ``q`` (rows, API layout)."""
    return model_mass_matrix_variation(scene.engine_model(), q)
