"""The geom pairs MuJoCo may collide, counted by MuJoCo's own filters rather than by geoms.

A geom with a nonzero ``contype`` or ``conaffinity`` can still collide with nothing: MuJoCo's
collision driver (``engine_collision_driver.c``) takes a pair of geoms from different bodies only if

* **weld filter**: their bodies are not welded together (``body_weldid`` equal: the same rigid
  body, the world's static geoms among them);
* **parent filter** (unless ``mjDSBL_FILTERPARENT``): neither welded body is the other's parent's
  welded body, the world excepted (a link never collides with the link it hangs from);
* **bit filter**: ``(contype1 & conaffinity2) || (contype2 & conaffinity1)``;
* **exclude**: the body pair is not in ``<contact><exclude>`` (``exclude_signature``, ``(b1 << 16) + b2``
  with ``b1 < b2``);
* **explicit pairs**: a ``<contact><pair>`` collides whatever the filters say, and replaces the
  dynamic pairs of its two bodies (``pair_signature``).

With contacts or constraints disabled (``mjDSBL_CONTACT``, ``mjDSBL_CONSTRAINT``: dm_control's
cartpole) nothing collides.
"""

from __future__ import annotations

import numpy as np


def _signature(b1: int, b2: int) -> int:
    lo, hi = (b1, b2) if b1 < b2 else (b2, b1)
    return (lo << 16) + hi


def collidable_pairs(m) -> list[tuple[int, int]]:
    """Every geom pair (g1 < g2) that MuJoCo's filters let through, explicit pairs included."""
    import mujoco

    bits = mujoco.mjtDisableBit
    if m.opt.disableflags & (int(bits.mjDSBL_CONTACT) | int(bits.mjDSBL_CONSTRAINT)):
        return []
    filterparent = not (m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT))
    excluded = {int(s) for s in np.asarray(m.exclude_signature).ravel()}
    explicit_bodies = {int(s) for s in np.asarray(m.pair_signature).ravel()}
    weld = np.asarray(m.body_weldid)
    parent = np.asarray(m.body_parentid)
    gbody = np.asarray(m.geom_bodyid)
    ctype = np.asarray(m.geom_contype)
    caff = np.asarray(m.geom_conaffinity)
    pairs = set()
    for g1 in range(m.ngeom):
        for g2 in range(g1 + 1, m.ngeom):
            b1, b2 = int(gbody[g1]), int(gbody[g2])
            w1, w2 = int(weld[b1]), int(weld[b2])
            if w1 == w2:
                continue
            if filterparent and w1 != 0 and w2 != 0 and (w1 == int(weld[parent[w2]]) or w2 == int(weld[parent[w1]])):
                continue
            if not (int(ctype[g1]) & int(caff[g2]) or int(ctype[g2]) & int(caff[g1])):
                continue
            sig = _signature(b1, b2)
            if sig in excluded or sig in explicit_bodies:
                continue
            pairs.add((g1, g2))
    for g1, g2 in zip(np.asarray(m.pair_geom1).ravel(), np.asarray(m.pair_geom2).ravel()):
        pairs.add((min(int(g1), int(g2)), max(int(g1), int(g2))))
    return sorted(pairs)
