"""A plugin engine whose releases are folders (``tests/test_engine_env.py``): ``toyengine`` is
imported from the folder a test puts first on PYTHONPATH, each folder one "release" with its
own step (``release_source``). The mode's model is the release's ``Model``."""

from __future__ import annotations


from adapters import EngineMode

RELEASE = '''"""toyengine {version}: semi-implicit Euler on a unit spring{note}."""
import numpy as np

VERSION = "{version}"


class Model:
    def __init__(self, scene, dt):
        q, v = scene.initial_state()
        self.q, self.v, self.dt = np.array(q, float), np.array(v, float), dt
        self.settings = {{"release": VERSION}}

    def advance(self):
        {step}

    def state(self):
        return self.q.copy(), self.v.copy()
'''

#: The step before and after the change: the later one adds the force as h*k*x/m with m = 1
#: written out, a product rounded differently (the last bits of some states change).
STEP_OLD = "self.v = self.v - self.dt * self.q; self.q = self.q + self.dt * self.v"
STEP_NEW = "self.v = self.v - (self.dt * 1.1) * self.q / 1.1; self.q = self.q + self.dt * self.v"


def release_source(version: str, changed: bool) -> str:
    return RELEASE.format(
        version=version,
        step=STEP_NEW if changed else STEP_OLD,
        note=", the force's product rounded differently" if changed else "",
    )


def write_releases(root, versions, first_changed: str):
    """One folder per release under ``root`` (``toyengine-<v>/toyengine/__init__.py`` and its
    dist-info), the step changed from ``first_changed`` on; returns {version: folder}."""
    from harness.execution.engine_env import version_key

    out = {}
    for v in versions:
        folder = root / f"toyengine-{v}"
        (folder / "toyengine").mkdir(parents=True)
        changed = version_key(v) >= version_key(first_changed)
        (folder / "toyengine" / "__init__.py").write_text(release_source(v, changed))
        info = folder / f"toyengine-{v}.dist-info"
        info.mkdir()
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: toyengine\nVersion: {v}\n")
        out[v] = folder
    return out


def build(engine, mode, scene, dt, count=False):
    return engine.Model(scene, dt)


METHODS = {
    "toyengine:euler": EngineMode(
        engine="toyengine",
        mode="euler",
        module="toyengine",
        dist="toyengine",
        build=build,
        scenes=("spring",),
        unsupported={},
        settings={},
        doc="semi-implicit Euler (a test's toy engine)",
    ),
}
