"""The pytest plugin that ``pyproject.toml`` registers (entry point ``integrator_harness``).

pytest imports it whenever the project is installed, so it must exist for the test suite to
start at all. It holds what the project's tests share; so far that is nothing beyond the
``slow`` marker, which the ini options also declare.
"""


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: long studies kept out of make test (run with -m slow)")
