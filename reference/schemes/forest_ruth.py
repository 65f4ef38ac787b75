"""Forest-Ruth, declared as its splitting (``reference.splitting``): three leapfrogs of lengths
theta h, (1 - 2 theta) h, theta h composed."""

from ..splitting import DRIFT, KICK, Splitting, splitting_scheme

#: theta = 1 / (2 - 2^(1/3)), the Forest-Ruth (Yoshida) coefficient.
THETA = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))

forest_ruth = splitting_scheme(
    "forest_ruth",
    Splitting(
        (DRIFT, "THETA/2"),
        (KICK, "THETA"),
        (DRIFT, "(1 - THETA)/2"),
        (KICK, "1 - 2*THETA"),
        (DRIFT, "(1 - THETA)/2"),
        (KICK, "THETA"),
        (DRIFT, "THETA/2"),
        constants={"THETA": THETA},
    ),
    order=4,
    module=__name__,
    homega_max=1.5734,
    # Not the chain and the cloth, where each pair would cost the standard suite a compile of its
    # own (RK4, the fourth order, runs there); the solar system, where the issue names it against
    # REBOUND's modes; the full suite runs it everywhere.
    suites={"standard": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "solar_system")},
    doc="""\
Forest-Ruth: three leapfrogs of lengths theta h, (1 - 2 theta) h, theta h composed,
theta = 1/(2 - 2^(1/3)):

        x += theta h/2 v;      v += theta h a(x);  x += (1 - theta) h/2 v;  v += (1 - 2 theta) h a(x)
        x += (1 - theta) h/2 v; v += theta h a(x); x += theta h/2 v

    Fourth order, symplectic, three evaluations; stable for h w <= 1.5734. Its kicks take a
    velocity-dependent force at the velocity before each kick, without a solve: first order there.
    """,
)
