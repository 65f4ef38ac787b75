"""Leapfrog, declared as its splitting (``reference.splitting``): drift h/2, kick h, drift h/2."""

from .._scheme import EVERY_SCENE
from ..splitting import DRIFT, KICK, Splitting, splitting_scheme

leapfrog = splitting_scheme(
    "leapfrog",
    Splitting((DRIFT, "1/2"), (KICK, 1), (DRIFT, "1/2")),
    order=2,
    module=__name__,
    suites={"standard": EVERY_SCENE},
    doc="""\
Leapfrog, drift-kick-drift (the form REBOUND's ``leapfrog`` integrates):

        x_{n+1/2} = x_n + (h/2) v_n
        v_{n+1}   = v_n + h a(x_{n+1/2})
        x_{n+1}   = x_{n+1/2} + (h/2) v_{n+1}

    Second order, symplectic, stable for h w <= 2. A velocity-dependent force is kicked with
    a(x_{n+1/2}, v_n), not the midpoint velocity, and nothing solves for it: first order there.
    """,
)
