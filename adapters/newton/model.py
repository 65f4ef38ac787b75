"""A model file (``harness model``) in Newton: the file as Newton's own loaders build it
(``ModelBuilder.add_urdf`` / ``add_mjcf``), stepped by SolverFeatherstone in the joint
coordinates, in float32; what ``adapters/newton/__init__.py``'s file model steps and reads back.

* **The model**: a URDF loaded with its root fixed (``floating=False``, Newton's URDF default,
  as MuJoCo compiles a URDF) and its fixed joints collapsed (``collapse_fixed_joints=True``: the
  links merged into their parent, as MuJoCo fuses them); an MJCF as Newton's parser builds it
  (a body without a joint welded to its parent; the joints of one body become one D6 joint, its
  linear axes first, at the first joint's position). ``finalize``'s inertia check is skipped (it
  raises a small or zero inertia to 1e-6: MuJoCo compiled the file's own). Gravity is MuJoCo's of
  the variant (the file's ``<option gravity>``, zero where the variant switches gravity off).
* **Every perturbing default off**: contacts (``solver.step(..., contacts=None)``: no collision
  pass, though the loaders build the file's shapes); joint drive gains (the loaders turn an
  MJCF position actuator's kp into ``joint_target_ke``: every ``joint_target_ke``/``kd`` set 0,
  the targets 0); SolverFeatherstone's angular damping (0.05: 0). The variant's switches
  (``scenarios.model.FEATURES``): damping (``joint_damping`` 0), limits (``joint_limit_lower``/
  ``upper`` at Newton's +-MAXVAL, none), armature (``joint_armature`` 0).
* **Coordinates**: the scene's are MuJoCo's qpos (hinge and slide joints by name). Each is the
  Newton degree of freedom of the joint of that name (a D6 joint's by its MJCF joints in Newton's
  order, linear first); Newton's coordinate is qpos less the joint's ``ref`` (MuJoCo's
  ``qpos0``). A model with a free or ball joint (a quaternion) is refused, as Drake refuses it.
* **What Newton ignores is listed, never silent**: every warning its loaders give, and each
  feature the variant keeps that SolverFeatherstone does not apply (joint friction, equality
  constraints, tendons, fluid drag, actuators at control 0; limits as penalty springs), is a note
  of the anatomy; every built quantity that differs from MuJoCo's is a line of the cross-engine
  comparison.
* **A file Newton refuses**: ``ValueError`` with Newton's own reason in one line.
"""

from __future__ import annotations

import collections
import warnings

import numpy as np

#: Newton's joint type numbers (``newton.JointType``).
_PRISMATIC, _REVOLUTE, _BALL, _FIXED, _FREE, _D6 = 0, 1, 2, 3, 4, 6


def one_line(exc: BaseException) -> str:
    return " ".join((str(exc) or type(exc).__name__).split())


def _mujoco_joints(m):
    """[(name, "hinge"/"slide", body name, qpos0)] of MuJoCo's hinge and slide joints."""
    import mujoco

    kinds = {int(mujoco.mjtJoint.mjJNT_HINGE): "hinge", int(mujoco.mjtJoint.mjJNT_SLIDE): "slide"}
    out = []
    for j in range(m.njnt):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"
        body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.jnt_bodyid[j])) or f"body{m.jnt_bodyid[j]}"
        out.append((name, kinds[int(m.jnt_type[j])], body, float(m.qpos0[m.jnt_qposadr[j]])))
    return out


def build_model(newton, scene):
    """(finalized model, gravity, facts) of the scene's file with every perturbing default off
    (module docstring); ValueError with Newton's reason where its loader refuses the file."""
    import mujoco

    if getattr(scene, "bullet_only", False):
        raise ValueError("newton: MuJoCo cannot compile the file, so the scene has no coordinates to map Newton's to")
    m = scene.engine_model()
    if m.nq != m.nv:
        raise ValueError("newton: a free or ball joint's quaternion is not mapped to the scene's coordinates")
    off = set(scene.switched_off)
    gravity = (
        [0.0, 0.0, 0.0]
        if m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY)
        else [float(g) for g in m.opt.gravity]
    )
    builder = newton.ModelBuilder(gravity=tuple(gravity))
    urdf = scene.file.kind == "URDF"
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        try:
            if urdf:
                builder.add_urdf(scene.file.path, floating=False, collapse_fixed_joints=True)
            else:
                builder.add_mjcf(scene.file.path)
            model = builder.finalize(device="cpu", skip_validation_inertia=True)
        except Exception as exc:  # Newton's loaders say why in a ValueError, a missing module in an ImportError
            raise ValueError(f"Newton cannot load it: {type(exc).__name__}: {one_line(exc)}") from None
    ignored = collections.Counter(f"{w.category.__name__}: {one_line(w.message)}" for w in said)
    facts = {
        "ignored": [f"newton: Newton's loader: {t}" + (f" ({n} times)" if n > 1 else "") for t, n in ignored.items()],
        "off": sorted(off),
        "kept": {f: scene.found[f] for f in scene.found if f not in off},
        "urdf": urdf,
        "mujoco": m,
        "target_gains": int(
            np.count_nonzero(model.joint_target_ke.numpy()) + np.count_nonzero(model.joint_target_kd.numpy())
        ),
    }
    # Drive gains off: at a target of 0 a position gain is a spring no MuJoCo actuator has at ctrl 0 as built here.
    model.joint_target_ke.zero_()
    model.joint_target_kd.zero_()
    if "damping" in off:
        model.joint_damping.zero_()
    if "limits" in off:
        model.joint_limit_lower.fill_(-newton.MAXVAL)
        model.joint_limit_upper.fill_(newton.MAXVAL)
    if "armature" in off:
        model.joint_armature.zero_()
    return model, gravity, facts


def _label(label: str) -> str:
    return label.rsplit("/", 1)[-1]


def coordinates(model, names, facts: dict):
    """(index into Newton's joint_q / joint_qd, offset: MuJoCo's qpos less Newton's coordinate,
    angular: whether each is a rotation) for each scene coordinate; ValueError where Newton's
    model has other coordinates than the scene's."""
    types = model.joint_type.numpy()
    q_start, qd_start = model.joint_q_start.numpy(), model.joint_qd_start.numpy()
    dof_dim = model.joint_dof_dim.numpy()
    child = model.joint_child.numpy()
    bodies = list(model.body_label)
    mj = _mujoco_joints(facts["mujoco"])
    ref = {name: q0 for name, _, _, q0 in mj}
    where: dict[str, tuple[int, int, bool]] = {}
    for j, label in enumerate(model.joint_label):
        kind = int(types[j])
        if kind == _FIXED:
            continue
        if kind in (_FREE, _BALL):
            raise ValueError(
                f"newton's model of the file has a {'free' if kind == _FREE else 'ball'} joint "
                f"{label!r}: its quaternion is not the scene's coordinates"
            )
        lin, ang = (
            (1, 0) if kind == _PRISMATIC else (0, 1) if kind == _REVOLUTE else (int(dof_dim[j][0]), int(dof_dim[j][1]))
        )
        if lin + ang == 1 and _label(label) in ref:
            dofs = [_label(label)]
        else:  # a D6 joint: the MJCF joints of its body, slides first, in file order
            body = _label(bodies[int(child[j])])
            own = [(n, k) for n, k, b, _ in mj if b == body]
            dofs = [n for n, k in own if k == "slide"] + [n for n, k in own if k == "hinge"]
            if len(dofs) != lin + ang:
                raise ValueError(
                    f"newton's joint {label!r} has {lin + ang} degrees of freedom, MuJoCo's body "
                    f"{body!r} {len(dofs)} joints"
                )
        for i, name in enumerate(dofs):
            where[name] = (int(q_start[j]) + i, int(qd_start[j]) + i, i >= lin)
    missing = [n for n in names if n not in where]
    if missing:
        raise ValueError(
            f"newton's model of the file has no joint named {missing[0]!r} "
            f"({model.joint_count} joints, the scene's {len(names)} coordinates)"
        )
    if model.joint_coord_count != len(names) or model.joint_dof_count != len(names):
        raise ValueError(
            f"newton's model of the file has {model.joint_coord_count} coordinates and "
            f"{model.joint_dof_count} velocities, the scene's {len(names)}"
        )
    q_index = np.array([where[n][0] for n in names], dtype=int)
    qd_index = np.array([where[n][1] for n in names], dtype=int)
    if not np.array_equal(q_index, qd_index):
        raise ValueError("newton's model of the file orders its coordinates and velocities differently")
    return q_index, np.array([ref[n] for n in names]), np.array([where[n][2] for n in names])


def settings(model, facts: dict) -> dict:
    """What the run records of the file's model (plain JSON values)."""
    return {
        "loaded": (
            "ModelBuilder.add_urdf(floating=False, collapse_fixed_joints=True)"
            if facts["urdf"]
            else "ModelBuilder.add_mjcf"
        ),
        "contacts": "none (solver.step gets contacts=None: no collision pass)",
        "joint_target_gains": f"0 (the file's {facts['target_gains']} nonzero drive gains set 0)",
        "inertia_validation": "skipped (it raises a small inertia to 1e-6)",
        "switched_off": facts["off"],
        "num_coordinates": int(model.joint_coord_count),
        "loader_warnings": [line.split("loader: ", 1)[1] for line in facts["ignored"]],
    }


def mass_matrix(solver, model) -> np.ndarray:
    """SolverFeatherstone's joint-space mass matrix H (block per articulation) plus the armature
    on its diagonal (the solver adds it to H in its Cholesky step), as the last step built it."""
    n = int(model.joint_dof_count)
    full = np.zeros((n, n))
    h = solver.H.numpy()
    starts, rows = solver.articulation_H_start.numpy(), solver.articulation_H_rows.numpy()
    dofs = solver.articulation_dof_start.numpy()
    for a in range(int(model.articulation_count)):
        r, s, d = int(rows[a]), int(starts[a]), int(dofs[a])
        full[d : d + r, d : d + r] = h[s : s + r * r].reshape(r, r)
    return full + np.diag(model.joint_armature.numpy().astype(float))


def anatomy(model, solver, index, offset, angular, names, facts: dict) -> dict:
    """What Newton built, at the state from which a step has just filled SolverFeatherstone's H and
    motion subspaces, in ``harness.measures.cross_engine``'s schema (module docstring)."""
    types, parent, child = model.joint_type.numpy(), model.joint_parent.numpy(), model.joint_child.numpy()
    inbound = {int(child[j]): j for j in range(model.joint_count)}
    mass, inertia = model.body_mass.numpy(), model.body_inertia.numpy()
    bodies = {}
    for b, label in enumerate(model.body_label):
        at, moves, rotates = b, False, False
        while at in inbound:
            j = inbound[at]
            kind = int(types[j])
            moves |= kind != _FIXED
            rotates |= kind in (_REVOLUTE, _BALL, _FREE) or kind == _D6 and int(model.joint_dof_dim.numpy()[j][1]) > 0
            at = int(parent[j])
        if not moves:
            continue  # welded to the world: no part of the dynamics
        bodies[_label(label)] = {
            "mass": float(mass[b]),
            "inertia": sorted(float(x) for x in np.linalg.eigvalsh(inertia[b].astype(float))),
            "rotates": rotates,
        }
    s = solver.joint_S_s.numpy().astype(float)
    lo, hi = model.joint_limit_lower.numpy(), model.joint_limit_upper.numpy()
    stiffness, rest = model.joint_stiffness.numpy(), model.joint_rest_q.numpy()
    damping, armature, friction = (
        model.joint_damping.numpy(),
        model.joint_armature.numpy(),
        model.joint_friction.numpy(),
    )
    joints, axes = {}, []
    for k, name in enumerate(names):
        d = int(index[k])
        axis = s[d][3:6] if angular[k] else s[d][0:3]
        axes.append(axis.tolist())
        limited = lo[d] > -newton_maxval() or hi[d] < newton_maxval()
        joints[name] = {
            "type": "hinge" if angular[k] else "slide",
            "axis": axis.tolist(),
            "stiffness": float(stiffness[d]),
            "spring_ref": float(rest[d]) + float(offset[k]),
            "damping": float(damping[d]),
            "armature": float(armature[d]),
            # SolverFeatherstone applies no joint friction (the loader reads it into joint_friction).
            "frictionloss": 0.0,
            "limits": [float(lo[d]) + float(offset[k]), float(hi[d]) + float(offset[k])] if limited else None,
        }
    full = mass_matrix(solver, model)
    notes = list(facts["ignored"])
    kept, m = facts["kept"], facts["mujoco"]
    read_friction = float(np.max(np.abs(friction))) if friction.size else 0.0
    for feature, why in (
        ("contact", "Newton steps it with no collision pass (contacts None), though its loader built the shapes"),
        ("frictionloss", f"SolverFeatherstone applies no joint friction (the loader read up to {read_friction:g})"),
        (
            "actuators",
            "the drive gains are set 0 and the control is zero: no actuator force (MuJoCo's act at "
            "ctrl 0, bias terms included)",
        ),
        ("equality", "SolverFeatherstone applies no equality constraints"),
        (
            "limits",
            "SolverFeatherstone holds a joint limit by a penalty spring (joint_limit_ke, joint_limit_kd), "
            "not a constraint",
        ),
        ("damping", "Newton has no fluid drag" if m.opt.density or m.opt.viscosity else None),
    ):
        if feature in kept and why:
            notes.append(f"newton: the model keeps {feature} ({kept[feature]}) and {why}")
    if m.ntendon:
        notes.append(f"newton: SolverFeatherstone applies none of the model's {m.ntendon} tendons")
    notes.append("newton: float32 throughout (Warp's float): each quantity carries 2^-24 of its size")
    return {
        "engine": "newton",
        "precision": "float32",
        "total_mass": float(sum(v["mass"] for v in bodies.values())),
        "mass_matrix": full[np.ix_(index, index)].tolist(),
        "joint_axes": axes,
        "bodies": bodies,
        "joints": joints,
        "notes": notes,
    }


def newton_maxval() -> float:
    import newton

    return float(np.float32(newton.MAXVAL))
