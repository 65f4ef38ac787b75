"""The method registry: one namespace of ids for reference schemes and engine modes.

``ref:NAME`` is a reference scheme (``reference.RefMethod``); ``ENGINE:MODE`` (``mujoco:euler``,
``rebound:whfast``, ...) is an engine mode from ``adapters``; modules named in ``$HARNESS_PLUGINS``
may add more (``load_plugins``). Every method is a ``records.Method``: it answers the same
questions (is it available, does it support a scene and if not why, ``simulate(scene, dt, steps,
every)``) and declares every optional capability; a plugin's method that leaves some out gets
their defaults here, once, where it is loaded (``as_method``).
"""

from __future__ import annotations

import importlib
import os

import adapters
import reference
from records import InvalidInput, Method, MethodId
from records.method_id import Option
from records.measures import Measure, get as registered_measure, register as register_measure
from records.measures import unregister as unregister_measure
from records.method import OPTIONAL, REQUIRED
from reference import RefMethod
from scenarios import Scene


class CompletedMethod:
    """A plugin's method that declares only part of ``records.Method``, with every capability it
    leaves out set to its default (``records.method.OPTIONAL``; ``family`` from its id;
    ``compiled_twin()`` itself): the one place where a method's attributes are looked for, so
    that the rest of the harness reads declared fields. One without a ``REQUIRED`` member is
    refused (InvalidInput, one line)."""

    def __init__(self, inner):
        missing = [name for name in REQUIRED if not hasattr(inner, name)]
        if missing:
            raise InvalidInput(
                f"method {getattr(inner, 'id', inner)!r} has no {', '.join(missing)} "
                f"(a method has {', '.join(REQUIRED)})"
            )
        self.inner = inner
        self.id = inner.id
        self.family = getattr(inner, "family", None) or MethodId.parse(inner.id).family
        for name, default in OPTIONAL.items():
            setattr(self, name, getattr(inner, name, default))
        self._twin = getattr(inner, "compiled_twin", None)

    def available(self) -> tuple[bool, str]:
        return self.inner.available()

    def supports(self, scene: Scene) -> tuple[bool, str]:
        return self.inner.supports(scene)

    def simulate(self, scene: Scene, dt: float, steps: int, every: int = 1, **kwargs):
        return self.inner.simulate(scene, dt, steps, every, **kwargs)

    def describe(self) -> dict:
        return self.inner.describe()

    def compiled_twin(self) -> Method:
        return self if self._twin is None else as_method(self._twin())

    def __repr__(self) -> str:
        return f"CompletedMethod({self.inner!r})"


def as_method(obj) -> Method:
    """``obj`` itself where it implements all of ``records.Method`` (a ``RefMethod``, an
    ``EngineMode``), else a :class:`CompletedMethod` around it (it must at least have ``id``,
    ``available()``, ``supports(scene)``, ``simulate(scene, dt, steps, every)`` and ``describe()``)."""
    return obj if isinstance(obj, Method) else CompletedMethod(obj)


def parse_options(items: list[str] | None) -> dict[str, str]:
    """``["iterations=5"]`` -> ``{"iterations": "5"}``; values are checked by ``get_method``."""
    out: dict[str, str] = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise InvalidInput(f"--opt {item!r} is not of the form key=value")
        out[name.strip()] = value.strip()
    return out


#: The most iterations a scheme's option takes (projection passes, Newton iterations, substeps).
MAX_ITERATIONS = 10**6
#: A reference scheme's counts that are its convergence knob (``Option.tighten``): a projection's
#: passes, ten times as many to converge further.
KNOBS = {"iterations": 10}


def declared_options(method: Method) -> dict[str, Option]:
    """The run-time options ``method`` takes, by name: a reference scheme's (``Scheme.options``,
    counts from 1; an implicit scheme's solve, ``RefMethod.options_declared``), an engine mode's
    (``EngineMode.options``); a plugin's method takes none."""
    if isinstance(method, RefMethod):
        scheme = method.scheme
        counts = {
            name: Option(name, int, 1, MAX_ITERATIONS, default=default, tighten=KNOBS.get(name))
            for name, default in scheme.options.items()
        }
        return {**counts, **scheme.kind.parameters(scheme), **method.options_declared}
    return dict(getattr(method, "options_declared", None) or {})


def convergence_knob(method: Method) -> Option | None:
    """The option that is ``method``'s convergence knob (declared with ``Option.tighten``: a
    projection's passes, an iterative solve's tolerance), None where it has none."""
    return next((o for o in declared_options(method).values() if o.tighten), None)


def tightened(method: Method) -> Method | None:
    """``method`` with its convergence knob tightened: its value (set, else the declared default)
    times ``tighten`` (ten times the passes, a tolerance a hundred times tighter), held to the
    option's range; None where it has no knob, or the knob is already at its end of the range."""
    knob = convergence_knob(method)
    if knob is None:
        return None
    value = (getattr(method, "options", None) or {}).get(knob.name, knob.default)
    if value is None:
        return None
    new = min(max(float(value) * knob.tighten, knob.low), knob.high)
    new = int(round(new)) if knob.type is int else new
    if new == value:
        return None
    return _with_options(method, {knob.name: new})


def _with_options(method: Method, options: dict) -> Method:
    valid = declared_options(method)
    checked = {}
    for name, value in options.items():
        if name not in valid:
            raise InvalidInput(
                f"unknown option {name!r} for method {MethodId.parse(method.id).base} "
                f"(valid: {', '.join(valid) or 'none'})"
            )
        checked[name] = valid[name].check(MethodId.parse(method.id).base, value)
    if not checked:
        return method
    return method.with_options(checked)


#: Environment variable naming plugin modules (``module[,module]``) that add methods.
PLUGINS_ENV = "HARNESS_PLUGINS"

_PLUGIN_METHODS: dict[str, dict] = {}  # module name -> the methods it registered, completed (as_method)
_PLUGIN_MEASURES: dict[str, tuple[Measure, ...]] = {}  # module name -> the measures it declares
_TASK_PLUGINS: tuple[str, ...] = ()  # in a worker: the plugins its current task names


def plugin_names(value: str | None = None) -> tuple[str, ...]:
    """The plugin modules named in ``value`` (default: ``$HARNESS_PLUGINS``), in order."""
    value = os.environ.get(PLUGINS_ENV, "") if value is None else value
    return tuple(dict.fromkeys(name.strip() for name in value.split(",") if name.strip()))


def load_plugins(names) -> dict[str, object]:
    """Import each plugin module once and return the methods they register, by id.

    A plugin module defines ``METHODS``, a dict from method id (``family:mode``) to a method
    object: an ``adapters.EngineMode``, or anything with ``id``, ``available()``,
    ``supports(scene)``, ``simulate(scene, dt, steps, every)`` and ``describe()``, whose other
    capabilities (``records.Method``) are then given their defaults here (:func:`as_method`). It may
    also, or instead, define ``MEASURES``, a list of ``records.measures.Measure``: each is
    registered, so every task, the history, the judge and the report take it.
    ``isolated = True`` steps it in a worker process, so an abort or a hang in it becomes a
    recorded result."""
    out: dict[str, object] = {}
    for name in names:
        if name not in _PLUGIN_METHODS:
            try:
                module = importlib.import_module(name)
            except ImportError as exc:
                raise InvalidInput(f"{PLUGINS_ENV}: plugin module {name!r} cannot be imported ({exc})") from None
            methods = getattr(module, "METHODS", None)
            declared = getattr(module, "MEASURES", None)
            if methods is None and declared is not None:
                methods = {}
            if not isinstance(methods, dict):
                raise InvalidInput(
                    f"{PLUGINS_ENV}: plugin module {name!r} defines no METHODS dict "
                    "(method id -> method object) and no MEASURES list"
                )
            _PLUGIN_MEASURES[name] = tuple(declared or ())
            for mid, m in methods.items():
                if getattr(m, "id", None) != mid or _plugin_family(mid) is None:
                    raise InvalidInput(
                        f"{PLUGINS_ENV}: plugin {name!r} registers {mid!r} for a method whose id is "
                        f"{getattr(m, 'id', None)!r} (ids are family:mode, the family not 'ref')"
                    )
            _PLUGIN_METHODS[name] = {mid: as_method(m) for mid, m in methods.items()}
        for measure in getattr(importlib.import_module(name), "MEASURES", None) or ():
            register_measure(measure)  # records.measures.Measure: registering it again changes nothing
        out.update(_PLUGIN_METHODS[name])
    return out


def _plugin_family(method_id) -> str | None:
    """The family of a plugin's method id, None where it is not ``family:mode`` or is ``ref``."""
    try:
        mid = MethodId.parse(method_id)
    except InvalidInput:
        return None
    return None if mid.reference else mid.family


def use_plugins(names) -> None:
    """In a worker: the plugins the task at hand names (a worker's environment is its
    forkserver's, which may predate ``$HARNESS_PLUGINS``); they replace the previous task's."""
    global _TASK_PLUGINS
    load_plugins(names)
    _TASK_PLUGINS = tuple(names)
    for module, declared in _PLUGIN_MEASURES.items():  # a previous task's plugin measures go with it
        if module not in active_plugins():
            for measure in declared:
                if registered_measure(measure.name) is measure:  # its own, not another of that name
                    unregister_measure(measure.name)


def active_plugins() -> tuple[str, ...]:
    """Plugin modules in effect: ``$HARNESS_PLUGINS``, and in a worker those its task names."""
    return tuple(dict.fromkeys((*plugin_names(), *_TASK_PLUGINS)))


def all_methods(compiled_where_bitwise: bool = False) -> dict[str, object]:
    """Every method id, reference schemes first, then engine modes (available or not), then
    the methods of the plugin modules in ``$HARNESS_PLUGINS``. ``compiled_where_bitwise``: the
    reference schemes step on their compiled loop wherever it computes the interpreted bits
    (``reference.RefMethod``); else interpreted."""
    out: dict[str, Method] = {
        m.id: m
        for m in (RefMethod(s, compiled_where_bitwise=compiled_where_bitwise) for s in reference.METHODS.values())
    }
    out.update(adapters.ENGINE_METHODS)
    for mid, m in load_plugins(active_plugins()).items():
        if mid in out and out[mid] is not m:
            raise InvalidInput(f"{PLUGINS_ENV}: a plugin registers {mid!r}, which is already a method")
        out[mid] = m
    return out


def get_method(method_id: str, options: dict | None = None, compiled_where_bitwise: bool = False) -> Method:
    """The method with that id (``records.MethodId``: options may be written into it,
    ``ref:xpbd?substeps=10&iterations=1``, ``drake:runge_kutta3@1e-6``); ``options``
    (``{"iterations": 5}``) set more of its run-time options; ``compiled_where_bitwise`` how a
    reference scheme steps (``all_methods``). The method's ``id`` is the canonical text of the id
    with its options."""
    mid = MethodId.parse(method_id)
    methods = all_methods(compiled_where_bitwise)
    if mid.base not in methods:
        raise InvalidInput(f"unknown method {mid.base!r} (valid: {', '.join(methods)})")
    given = dict(mid.options)
    for name, value in (options or {}).items():
        given[name] = value
    return _with_options(methods[mid.base], given)


def check_supported(method: Method, scene: Scene) -> None:
    ok, why = method.available()
    if not ok:
        raise InvalidInput(f"method {method.id} is unavailable: {why}")
    ok, why = method.supports(scene)
    if not ok:
        raise InvalidInput(f"method {method.id} does not support scene {scene.id}: {why}")
