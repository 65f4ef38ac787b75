"""Method ids, one namespace for reference schemes and engine modes.

``ref:NAME`` is a reference scheme; ``ENGINE:MODE`` (``mujoco:euler``, ``rebound:whfast``, ...)
is an engine mode from ``adapters``; modules named in ``$HARNESS_PLUGINS`` may add more
(``load_plugins``). Every method answers the same questions: is it
available, does it support a scene (and if not, why), and ``simulate(scene, dt, steps, every)``.
"""
from __future__ import annotations

import importlib
import os
from dataclasses import dataclass, field

import adapters
import reference
from records import InvalidInput, Trajectory
from scenarios import Scene
from scenarios.scene import no_solve


@dataclass(frozen=True)
class RefMethod:
    """A reference scheme as a method. ``options`` are the run-time options the scheme declares
    (``Scheme.options``: a constrained scheme's projection ``iterations``); unset ones keep the
    scheme's defaults. ``compiled`` picks the compiled driver (same states, not counted)."""

    scheme: reference.Scheme
    options: dict = field(default_factory=dict, compare=False)
    #: Step on the compiled path (``reference.integrate_compiled``): the same states, for runs
    #: too long to interpret; force evaluations are then not counted.
    compiled: bool = field(default=False, compare=False)

    @property
    def id(self) -> str:
        return f"ref:{self.scheme.id}"

    family = "ref"
    engine = "reference"
    isolated = False

    def available(self) -> tuple[bool, str]:
        return True, ""

    def supports(self, scene: Scene) -> tuple[bool, str]:
        if self.scheme.constrained and not scene.constrained:
            return False, (f"scene {scene.id} has no constraints to project "
                           f"(without them {self.id} is plain ref:verlet)")
        if scene.constrained and not self.scheme.constrained:
            return False, (f"scene {scene.id} is held together by constraints that only a constrained "
                           f"scheme enforces (ref:verlet_constrained); here its particles would fall freely")
        if self.scheme.decay and not scene.has_damping_rate:
            return False, (f"scene {scene.id} has no single linear damping rate for {self.id} to decay "
                           "(it needs a(x, v) = a(x, 0) - gamma v with one rate gamma)")
        if self.scheme.implicit and type(scene).solve is no_solve:
            return False, f"scene {scene.id} provides no implicit solve"
        return True, ""

    def compiled_twin(self) -> "RefMethod":
        return RefMethod(self.scheme, self.options, compiled=True)

    def simulate(self, scene: Scene, dt: float, steps: int, every: int = 1) -> Trajectory:
        if self.compiled:
            return reference.integrate_compiled(self.scheme, scene, dt, steps, every, **self.options)
        return reference.integrate(self.scheme, scene, dt, steps, every, **self.options)

    def describe(self) -> dict:
        return {"id": self.id, "family": "ref", **{k: v for k, v in self.scheme.describe().items() if k != "id"}}


def parse_options(items: list[str] | None) -> dict[str, str]:
    """``["iterations=5"]`` -> ``{"iterations": "5"}``; values are checked by ``get_method``."""
    out: dict[str, str] = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise InvalidInput(f"--opt {item!r} is not of the form key=value")
        out[name.strip()] = value.strip()
    return out


def _with_options(method, options: dict) -> object:
    valid = method.scheme.options if isinstance(method, RefMethod) else {}
    checked = {}
    for name, value in options.items():
        if name not in valid:
            raise InvalidInput(f"unknown option {name!r} for method {method.id} "
                               f"(valid: {', '.join(valid) or 'none'})")
        try:
            x = int(value)
            ok = x == float(value) and x >= 1
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise InvalidInput(f"option {name}={value} is out of range (allowed: integer >= 1)")
        checked[name] = x
    return RefMethod(method.scheme, checked) if checked else method


#: Environment variable naming plugin modules (``module[,module]``) that add methods.
PLUGINS_ENV = "HARNESS_PLUGINS"

_PLUGIN_METHODS: dict[str, dict] = {}   # module name -> the methods it registered
_TASK_PLUGINS: tuple[str, ...] = ()     # in a worker: the plugins its current task names


def plugin_names(value: str | None = None) -> tuple[str, ...]:
    """The plugin modules named in ``value`` (default: ``$HARNESS_PLUGINS``), in order."""
    value = os.environ.get(PLUGINS_ENV, "") if value is None else value
    return tuple(dict.fromkeys(name.strip() for name in value.split(",") if name.strip()))


def load_plugins(names) -> dict[str, object]:
    """Import each plugin module once and return the methods they register, by id.

    A plugin module defines ``METHODS``, a dict from method id (``family:mode``) to a method
    object: anything with ``id``, ``family``, ``isolated``, ``available()``, ``supports(scene)``,
    ``simulate(scene, dt, steps, every)`` and ``describe()``, as an engine mode has
    (``adapters._base.EngineMode``). ``isolated = True`` steps it in a worker process, so an
    abort or a hang in it becomes a recorded result."""
    out: dict[str, object] = {}
    for name in names:
        if name not in _PLUGIN_METHODS:
            try:
                module = importlib.import_module(name)
            except ImportError as exc:
                raise InvalidInput(f"{PLUGINS_ENV}: plugin module {name!r} cannot be imported ({exc})") from None
            methods = getattr(module, "METHODS", None)
            if not isinstance(methods, dict):
                raise InvalidInput(f"{PLUGINS_ENV}: plugin module {name!r} defines no METHODS dict "
                                   "(method id -> method object)")
            for mid, m in methods.items():
                if getattr(m, "id", None) != mid or ":" not in mid or mid.startswith("ref:"):
                    raise InvalidInput(f"{PLUGINS_ENV}: plugin {name!r} registers {mid!r} for a method whose id is "
                                       f"{getattr(m, 'id', None)!r} (ids are family:mode, the family not 'ref')")
            _PLUGIN_METHODS[name] = dict(methods)
        out.update(_PLUGIN_METHODS[name])
    return out


def use_plugins(names) -> None:
    """In a worker: the plugins the task at hand names (a worker's environment is its
    forkserver's, which may predate ``$HARNESS_PLUGINS``); they replace the previous task's."""
    global _TASK_PLUGINS
    load_plugins(names)
    _TASK_PLUGINS = tuple(names)


def active_plugins() -> tuple[str, ...]:
    """Plugin modules in effect: ``$HARNESS_PLUGINS``, and in a worker those its task names."""
    return tuple(dict.fromkeys((*plugin_names(), *_TASK_PLUGINS)))


def all_methods() -> dict[str, object]:
    """Every method id, reference schemes first, then engine modes (available or not), then
    the methods of the plugin modules in ``$HARNESS_PLUGINS``."""
    out: dict[str, object] = {f"ref:{sid}": RefMethod(s) for sid, s in reference.METHODS.items()}
    out.update(adapters.ENGINE_METHODS)
    for mid, m in load_plugins(active_plugins()).items():
        if mid in out and out[mid] is not m:
            raise InvalidInput(f"{PLUGINS_ENV}: a plugin registers {mid!r}, which is already a method")
        out[mid] = m
    return out


def get_method(method_id: str, options: dict | None = None):
    """The method with that id; ``options`` (``{"iterations": 5}``) set a scheme's run-time options."""
    methods = all_methods()
    if method_id not in methods:
        raise InvalidInput(f"unknown method {method_id!r} (valid: {', '.join(methods)})")
    return _with_options(methods[method_id], options or {})


def check_supported(method, scene: Scene) -> None:
    ok, why = method.available()
    if not ok:
        raise InvalidInput(f"method {method.id} is unavailable: {why}")
    ok, why = method.supports(scene)
    if not ok:
        raise InvalidInput(f"method {method.id} does not support scene {scene.id}: {why}")
