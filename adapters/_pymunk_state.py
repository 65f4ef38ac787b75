"""Reading a pymunk space's bodies in one Chipmunk call (``pymunk.batch``), for the poses with
many bodies (``adapters.pymunk``): per-step reads property by property were most of a stability
search's time on the rope."""
from __future__ import annotations

import numpy as np


class BodyReader:
    """Every body's position and velocity, rows in ``bodies`` order (shape (n, 2) each): one
    Chipmunk call where the space lists these bodies first and in this order (the static body
    follows them), checked by their ids once; property by property otherwise. The same doubles
    either way: the batch copies Chipmunk's own."""

    def __init__(self, space, bodies):
        from pymunk import batch

        self.space, self.bodies, self.batch = space, bodies, batch
        ids = batch.Buffer()
        batch.get_space_bodies(space, batch.BodyFields.BODY_ID, ids)
        n = len(bodies)
        self.batched = np.frombuffer(ids.int_buf(), dtype=np.uintp)[:n].tolist() == [b.id for b in bodies]
        self.buffer = batch.Buffer()
        self.fields = batch.BodyFields.POSITION | batch.BodyFields.VELOCITY

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.batched:
            return (np.array([tuple(b.position) for b in self.bodies]).reshape(-1, 2),
                    np.array([tuple(b.velocity) for b in self.bodies]).reshape(-1, 2))
        self.buffer.clear()
        self.batch.get_space_bodies(self.space, self.fields, self.buffer)
        rows = np.frombuffer(self.buffer.float_buf(), dtype=float).reshape(-1, 4)[:len(self.bodies)]
        return rows[:, :2].copy(), rows[:, 2:].copy()
