"""Node plugins: users' own behaviours as node types of a mission's ``tree:``.

Two routes, both ending in the same call a built-in behaviour module makes —
``register(registry: NodeRegistry) -> None``, which calls ``registry.register(type_name, factory,
params_model)`` with a pydantic model (``extra="forbid"``) of the node's ``params``:

- **a mission's** ``plugins: [module, ...]``: each module is imported (from ``sys.path``, then
  from the mission file's folder) and its ``register`` adds node types to that mission's registry
  only (a copy of the default one);
- **installed packages**: an entry point in the group ``marknav.nodes`` naming a module with
  ``register``, or the ``register`` callable itself (``pyproject.toml``:
  ``[project.entry-points."marknav.nodes"] wiggle = "wiggle_nodes"``). Entry points are loaded
  into the default registry, so ``marknav schema`` and every mission see them.

A plugin that cannot be imported, has no ``register`` or whose ``register`` fails is an
:class:`~marknav.core.errors.InputError`: for a mission's plugin at its line in the file
(``FILE:LINE:COLUMN: plugins[0]: ...``), for an entry point naming the distribution.
"""

from __future__ import annotations

import importlib
import logging
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager, suppress
from importlib import metadata
from pathlib import Path
from types import ModuleType
from typing import Any

from marknav.core.errors import InputError
from marknav.missions.registry import NodeRegistry

log = logging.getLogger(__name__)

#: The entry-point group installed packages use to add node types.
ENTRY_POINT_GROUP = "marknav.nodes"

Register = Callable[["NodeRegistry"], None]


class PluginError(Exception):
    """A plugin could not be loaded; the message says why (located by the caller)."""


def _register_of(obj: Any, what: str) -> Register:
    if isinstance(obj, ModuleType):
        fn = getattr(obj, "register", None)
        if fn is None:
            raise PluginError(f"{what} has no register(registry) function")
        obj = fn
    if not callable(obj):
        raise PluginError(f"{what} is not a module or a register(registry) callable")
    return obj


def _call(register: Register, registry: NodeRegistry, what: str) -> None:
    try:
        register(registry)
    except (ValueError, TypeError, KeyError, AttributeError) as exc:
        raise PluginError(f"{what}: register() failed: {exc}") from exc


@contextmanager
def _searching(folder: Path | None) -> Iterator[None]:
    """``folder`` at the front of ``sys.path`` for the duration (a mission's own modules)."""
    if folder is None:
        yield
        return
    entry = str(folder)
    sys.path.insert(0, entry)
    try:
        yield
    finally:
        with suppress(ValueError):  # the plugin may have removed it itself
            sys.path.remove(entry)


def import_plugin(module_name: str, folder: Path | None = None) -> ModuleType:
    """Import a mission's plugin module (``sys.path``, then ``folder``)."""
    if not isinstance(module_name, str) or not module_name.strip():
        raise PluginError("a plugin is a Python module name, e.g. my_nodes or mypkg.nodes")
    with _searching(folder):
        try:
            return importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name is not None and module_name.startswith(exc.name):
                where = f" (looked on sys.path and in {folder})" if folder is not None else ""
                raise PluginError(f"no module named {module_name!r}{where}") from exc
            raise PluginError(f"importing {module_name!r} failed: {exc}") from exc
        except Exception as exc:  # a user's module may raise anything while importing
            raise PluginError(
                f"importing {module_name!r} failed: {type(exc).__name__}: {exc}") from exc


#: ``register`` functions already run for the default registry through an entry point: a mission
#: that also lists the module under ``plugins:`` (installed *and* named) must not register twice.
_from_entry_points: set[Register] = set()


def add_module_plugin(registry: NodeRegistry, module_name: str, folder: Path | None = None) -> None:
    """Import ``module_name`` and call its ``register(registry)``; :class:`PluginError` if not.
    A module whose ``register`` an installed package's entry point already ran is left alone."""
    module = import_plugin(module_name, folder)
    register = _register_of(module, f"module {module_name!r}")
    if register in _from_entry_points:
        log.debug("plugin %s: already registered through its entry point", module_name)
        return
    _call(register, registry, module_name)


def _entry_points() -> Sequence[metadata.EntryPoint]:
    return tuple(metadata.entry_points(group=ENTRY_POINT_GROUP))


def add_entry_point_plugins(registry: NodeRegistry) -> list[str]:
    """Load every ``marknav.nodes`` entry point into ``registry``; the names loaded, in order.
    A broken one raises :class:`InputError` naming the entry point and its distribution."""
    loaded: list[str] = []
    for ep in sorted(_entry_points(), key=lambda e: (e.name != "marknav", e.name)):
        dist = ep.dist.name if ep.dist is not None else "?"
        what = f"entry point {ENTRY_POINT_GROUP} {ep.name} = {ep.value} (package {dist})"
        try:
            try:
                obj = ep.load()
            except Exception as exc:  # a user's package may raise anything while importing
                raise PluginError(f"loading failed: {type(exc).__name__}: {exc}") from exc
            register = _register_of(obj, repr(ep.value))
            _call(register, registry, ep.value)
            _from_entry_points.add(register)
        except PluginError as exc:
            raise InputError(f"{what}: {exc}") from None
        log.debug("node plugin %s loaded", what)
        loaded.append(ep.name)
    return loaded


def registry_with_plugins(
    modules: Sequence[str], folder: Path | None, base: NodeRegistry
) -> tuple[NodeRegistry, list[tuple[int, str]]]:
    """A copy of ``base`` with a mission's ``plugins`` modules registered, and the problems as
    ``(index in modules, message)``; a module that fails adds nothing (its node types then show
    up as unknown)."""
    registry = base.copy()
    problems: list[tuple[int, str]] = []
    for i, module_name in enumerate(modules):
        trial = registry.copy()
        try:
            add_module_plugin(trial, module_name, folder)
        except PluginError as exc:
            problems.append((i, str(exc)))
            continue
        registry = trial
    return registry, problems


_default: NodeRegistry | None = None
_default_lock = threading.Lock()


def default_registry() -> NodeRegistry:
    """The process-wide registry: every installed package's node types (entry-point group
    ``marknav.nodes``), marknav's own first among them (:mod:`marknav.behaviours.catalogue`)."""
    global _default
    with _default_lock:
        if _default is None:
            registry = NodeRegistry()
            loaded = add_entry_point_plugins(registry)
            if "marknav" not in loaded:
                raise InputError(
                    "marknav's own node types are not registered: the package's entry points "
                    "are missing (install it with 'pip install -e .' or 'pip install marknav')")
            _default = registry
        return _default
