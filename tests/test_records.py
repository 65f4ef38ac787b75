"""records/: the divergence test every run asks at every step."""
import numpy as np
import pytest

from records.trajectory import DIVERGED, diverged


def componentwise(q, v) -> bool:
    """The rule, spelled out: some component not finite, or beyond DIVERGED."""
    x = np.concatenate([np.ravel(q), np.ravel(v)])
    return bool(np.any(~np.isfinite(x)) or np.any(np.abs(x) > DIVERGED))


@pytest.mark.parametrize("value", [0.0, 1.0, -3e99, DIVERGED, -DIVERGED, np.nextafter(DIVERGED, np.inf), 1e101,
                                   1e160, -1e200, np.inf, -np.inf, np.nan])
@pytest.mark.parametrize("where", ["q", "v"])
def test_diverged_is_the_componentwise_rule(value, where):
    """Edge values in either half of the state (NaN in v alone included), among ordinary ones."""
    q, v = np.array([0.5, -2.0, 1e3]), np.array([0.1, 7.0, -1e-300])
    (q if where == "q" else v)[1] = value
    assert diverged(q, v) == componentwise(q, v)


def test_diverged_agrees_with_the_rule_on_random_states_across_every_scale():
    """Many components each just under DIVERGED (their squares' sum passes the fast bound, so the
    componentwise test decides), and random magnitudes from 1e-300 to 1e300."""
    rng = np.random.default_rng(7)
    q = np.full(100, 0.99 * DIVERGED)
    assert not diverged(q, np.zeros(3)) and not componentwise(q, np.zeros(3))
    for _ in range(2000):
        n = rng.integers(1, 12)
        q = rng.choice([-1, 1], n) * 10.0 ** rng.uniform(-300, 300, n)
        v = rng.choice([-1, 1], (n, 2)) * 10.0 ** rng.uniform(-300, 300, (n, 2))
        assert diverged(q, v) == componentwise(q, v)
