"""Behaviour-tree node types a mission's ``tree:`` section may use, and building trees from it.

A :class:`NodeRegistry` maps a type name (``Sequence``, ``Retry``, ``Pause``, later marknav's own
``ApproachWhileCentring``...) to a factory and a pydantic model of its ``params``, so a mission's
tree is checked completely when the file is loaded — unknown types (with a did-you-mean), a
Sequence without ``memory``, a decorator without its ``child``, bad ``params`` — with the file
line of each problem, long before the robot moves.

A node in YAML::

    type: Sequence | Selector | Parallel | <decorator> | <behaviour>
    name: Route                  # optional; defaults to the type name
    memory: true                 # Sequence and Selector only, required (py_trees 2.6 needs it)
    policy: success_on_all       # Parallel only, required: success_on_all | success_on_one
    params: {num_failures: 3}    # checked against the type's parameter model
    children: [...]              # composites
    child: {...}                 # decorators

Built in (:mod:`marknav.behaviours.builtin_nodes`): the py_trees composites, its
status-converting decorators, ``Retry``, ``Repeat``, ``OneShot``, the leaves ``Success``,
``Failure``, ``Running``, ``TickCounter``, and marknav's clock-driven ``Pause`` and ``Timeout``
(:mod:`marknav.behaviours.pause`; py_trees' own timers read the wall clock, which a simulated run
must not). ``EternalGuard`` is not offered: its condition is a Python callable, which a YAML file
cannot name safely; a Sequence with ``memory: false`` and a condition leaf first is the
equivalent.

This module is a leaf: it knows no node type. Modules register theirs into a registry — the
built-ins, marknav's behaviours (:mod:`marknav.behaviours.nodes`) and users' plugins — and
:func:`marknav.behaviours.catalogue.default_registry` is the registry holding all of them.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, Protocol

from py_trees.behaviour import Behaviour
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ModelWrapValidatorHandler,
    ValidationError,
    ValidationInfo,
    model_validator,
)
from pydantic_core import ErrorDetails, InitErrorDetails, PydanticCustomError

from marknav.core.errors import InputError, InputErrors

if TYPE_CHECKING:
    from marknav.core.yamlio import YamlDocument

Loc = tuple[str | int, ...]
NodeKind = Literal["composite", "decorator", "leaf"]

#: Error type of an unknown key found by :func:`model_problems` (the message carries the
#: did-you-mean); the mission loader points these at the key, like yamlio's own unknown keys.
UNKNOWN_KEY = "unknown_key"

_TYPE_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


# --------------------------------------------------------------------------------------------
# The node specification (what a mission's ``tree:`` holds)
# --------------------------------------------------------------------------------------------


class TreeNode(BaseModel):
    """One node of a custom behaviour tree: a composite, a decorator or a registered behaviour."""

    model_config = ConfigDict(extra="forbid", title="TreeNode")

    type: str = Field(
        description="Node type: Sequence, Selector, Parallel, a decorator (Retry, Timeout, "
        "Inverter, ...) or a registered behaviour (Pause, Success, ...).",
    )
    name: str | None = Field(
        default=None, min_length=1,
        description="Name shown in the tree display; defaults to the type.",
    )
    memory: bool | None = Field(
        default=None,
        description="Sequence and Selector only, required. true: resume at the child that was "
        "running; false: restart from the first child every tick (reactive).",
    )
    policy: Literal["success_on_all", "success_on_one"] | None = Field(
        default=None,
        description="Parallel only, required: succeed when all children succeed, or when one does.",
    )
    params: dict[str, Any] = Field(
        default_factory=dict,
        description="Parameters of the node type (e.g. Retry: {num_failures: 3}).",
    )
    children: list[TreeNode] | None = Field(
        default=None,
        description="Child nodes of a composite (Sequence, Selector, Parallel), in order.",
    )
    child: TreeNode | None = Field(default=None, description="The one child node of a decorator.")

    @model_validator(mode="wrap")
    @classmethod
    def _check_against_registry(
        cls, data: Any, handler: ModelWrapValidatorHandler[TreeNode], info: ValidationInfo
    ) -> TreeNode:
        """Structure errors (from pydantic) and registry errors (type, memory, policy, params,
        child/children), reported together."""
        problems: list[InitErrorDetails] = []
        node: TreeNode | None = None
        try:
            node = handler(data)
        except ValidationError as exc:
            problems.extend(relocated(exc.errors(include_url=False)))
        raw = data.model_dump() if isinstance(data, TreeNode) else data
        if isinstance(raw, Mapping):
            registry = info.context.get("registry") if isinstance(info.context, dict) else None
            if registry is not None:  # the loader passes one; without, the structure only
                problems.extend(registry.check(raw))
        if problems:
            # pydantic 2.14 may run this validator twice for the same node when the model is
            # reached through a definition reference (the handler holds a second copy of it):
            # report each problem once.
            unique = {(p["loc"], _text(p)): p for p in problems}
            raise ValidationError.from_exception_data("TreeNode", list(unique.values()))
        assert node is not None
        return node


# --------------------------------------------------------------------------------------------
# Registry
# --------------------------------------------------------------------------------------------


class NoParams(BaseModel):
    """A node type without parameters."""

    model_config = ConfigDict(extra="forbid")


class LoadedMission(Protocol):
    """What building a tree needs of the loaded mission itself: its YAML document, to place
    errors at their line. (:class:`marknav.missions.schema.Mission` is one; factories that read
    its settings narrow it with ``isinstance``: the registry sits below the schema.)"""

    @property
    def document(self) -> YamlDocument | None: ...


@dataclass(frozen=True)
class BuildContext:
    """What factories may use beyond a node's own params: the loaded mission (palette, robot,
    navigation settings, and its YAML document for line-numbered errors), plus free options."""

    mission: LoadedMission | None = None
    options: Mapping[str, Any] = field(default_factory=dict)


#: ``factory(name, params, context)`` for a leaf behaviour.
LeafFactory = Callable[[str, Any, BuildContext], Behaviour]
#: ``factory(name, child, params, context)`` for a decorator.
DecoratorFactory = Callable[[str, Behaviour, Any, BuildContext], Behaviour]
#: ``factory(name, children, node, context)`` for a composite (reads ``node.memory``/``policy``).
CompositeFactory = Callable[[str, list[Behaviour], TreeNode, BuildContext], Behaviour]


@dataclass(frozen=True)
class NodeType:
    """A registered node type."""

    name: str
    kind: NodeKind
    factory: Callable[..., Behaviour]
    params_model: type[BaseModel]
    description: str
    needs_memory: bool = False
    needs_policy: bool = False


class NodeRegistry:
    """Node type name -> factory and parameter model."""

    def __init__(self) -> None:
        self._types: dict[str, NodeType] = {}

    # registration ---------------------------------------------------------------------------

    def register(
        self,
        type_name: str,
        factory: LeafFactory | DecoratorFactory,
        params_model: type[BaseModel] = NoParams,
        *,
        leaf: bool = True,
        description: str | None = None,
        replace: bool = False,
    ) -> None:
        """Register a leaf behaviour (``leaf=True``: ``factory(name, params, context)``) or a
        decorator (``leaf=False``: ``factory(name, child, params, context)``).

        ``params`` are validated against ``params_model`` (a pydantic model with
        ``extra="forbid"``) when the mission loads, and the factory receives the model instance.
        """
        self._add(
            type_name,
            "leaf" if leaf else "decorator",
            factory,
            params_model,
            description=description,
            replace=replace,
        )

    def register_composite(
        self,
        type_name: str,
        factory: CompositeFactory,
        *,
        needs_memory: bool = False,
        needs_policy: bool = False,
        description: str | None = None,
        replace: bool = False,
    ) -> None:
        """Register a composite: ``factory(name, children, node, context)``."""
        self._add(
            type_name,
            "composite",
            factory,
            NoParams,
            description=description,
            replace=replace,
            needs_memory=needs_memory,
            needs_policy=needs_policy,
        )

    def _add(
        self,
        type_name: str,
        kind: NodeKind,
        factory: Callable[..., Behaviour],
        params_model: type[BaseModel],
        *,
        description: str | None,
        replace: bool,
        needs_memory: bool = False,
        needs_policy: bool = False,
    ) -> None:
        if not _TYPE_NAME.match(type_name):
            raise ValueError(f"node type name {type_name!r} must be an identifier (A-Z, 0-9, _)")
        if type_name in self._types and not replace:
            raise ValueError(f"node type {type_name!r} is already registered")
        if not callable(factory):
            raise TypeError(f"factory for {type_name!r} is not callable")
        if not (isinstance(params_model, type) and issubclass(params_model, BaseModel)):
            raise TypeError(f"params_model for {type_name!r} must be a pydantic model class")
        if params_model.model_config.get("extra") != "forbid":
            raise ValueError(
                f"params_model {params_model.__name__} for {type_name!r} must set "
                "model_config = ConfigDict(extra='forbid') so misspelt params are rejected"
            )
        if description is None:
            doc = params_model.__doc__ if params_model is not NoParams else factory.__doc__
            description = (doc or "").strip().splitlines()[0] if doc and doc.strip() else ""
        self._types[type_name] = NodeType(
            type_name, kind, factory, params_model, description, needs_memory, needs_policy
        )

    # queries --------------------------------------------------------------------------------

    def __contains__(self, type_name: object) -> bool:
        return type_name in self._types

    def __len__(self) -> int:
        return len(self._types)

    def __iter__(self) -> Iterator[NodeType]:
        return iter(self._types.values())

    def names(self) -> list[str]:
        """Registered type names, sorted."""
        return sorted(self._types)

    def get(self, type_name: str) -> NodeType:
        """The node type; :class:`KeyError` with a did-you-mean if unknown."""
        try:
            return self._types[type_name]
        except KeyError:
            raise KeyError(self.unknown_message(type_name)) from None

    def unknown_message(self, type_name: str) -> str:
        close = difflib.get_close_matches(type_name, list(self._types), n=1)
        if close:
            return f"unknown node type {type_name!r}; did you mean {close[0]!r}?"
        return f"unknown node type {type_name!r} (known: {', '.join(self.names())})"

    def copy(self) -> NodeRegistry:
        """An independent registry with the same types (to extend without touching this one)."""
        other = NodeRegistry()
        other._types = dict(self._types)
        return other

    # checking -------------------------------------------------------------------------------

    def check(self, node: Mapping[str, Any]) -> list[InitErrorDetails]:
        """Registry-dependent problems of one raw node mapping (not its descendants), with
        locations relative to the node. Structure (types of values, unknown keys) is left to
        :class:`TreeNode`'s own validation."""
        type_name = node.get("type")
        if not isinstance(type_name, str):
            return []
        if type_name not in self._types:
            return [_detail("node_type", self.unknown_message(type_name), ("type",), type_name)]
        spec = self._types[type_name]
        out: list[InitErrorDetails] = []
        memory_types = " and ".join(t.name for t in self if t.needs_memory) or "no node type"
        if spec.needs_memory and node.get("memory") is None:
            out.append(_detail(
                "node_memory",
                f"{type_name} needs 'memory: true' (resume at the running child) or "
                "'memory: false' (restart from the first child every tick)",
                ("memory",), None,
            ))
        elif not spec.needs_memory and node.get("memory") is not None:
            out.append(_detail(
                "node_memory", f"'memory' applies only to {memory_types}, not {type_name}",
                ("memory",), node.get("memory"),
            ))
        policy_types = " and ".join(t.name for t in self if t.needs_policy) or "no node type"
        if spec.needs_policy and node.get("policy") is None:
            out.append(_detail(
                "node_policy",
                f"{type_name} needs 'policy: success_on_all' or 'policy: success_on_one'",
                ("policy",), None,
            ))
        elif not spec.needs_policy and node.get("policy") is not None:
            out.append(_detail(
                "node_policy", f"'policy' applies only to {policy_types}, not {type_name}",
                ("policy",), node.get("policy"),
            ))
        out.extend(_shape_problems(spec, node))
        params = node.get("params")
        if params is None:
            params = {}
        if isinstance(params, Mapping):
            out.extend(_params_problems(spec, params))
        return out

    def validate_params(self, type_name: str, params: Mapping[str, Any]) -> BaseModel:
        """``params`` as the type's parameter model; :class:`ValueError` if they do not fit."""
        spec = self.get(type_name)
        problems = _params_problems(spec, params)
        if problems:
            raise ValueError("; ".join(_text(p) for p in problems))
        return spec.params_model.model_validate(dict(params))

    def json_schema_conditions(self, defs: dict[str, Any]) -> list[dict[str, Any]]:
        """JSON Schema ``if``/``then`` clauses, one per type, so editors check each node's
        params and required keys; parameter models' own ``$defs`` are merged into ``defs``."""
        clauses: list[dict[str, Any]] = []
        for spec in sorted(self, key=lambda t: t.name):
            params_schema = spec.params_model.model_json_schema(ref_template="#/$defs/{model}")
            defs.update(params_schema.pop("$defs", {}))
            params_schema.pop("title", None)
            if spec.description:
                params_schema["description"] = f"{spec.name}: {spec.description}"
            required = [k for k, needed in (
                ("memory", spec.needs_memory),
                ("policy", spec.needs_policy),
                ("children", spec.kind == "composite"),
                ("child", spec.kind == "decorator"),
            ) if needed]
            then: dict[str, Any] = {"properties": {"params": params_schema}}
            if required:
                then["required"] = required
            clauses.append({
                "if": {"properties": {"type": {"const": spec.name}}, "required": ["type"]},
                "then": then,
            })
        return clauses


def _detail(kind: str, message: str, loc: Loc, value: Any) -> InitErrorDetails:
    return InitErrorDetails(type=PydanticCustomError(kind, message), loc=loc, input=value)


def _text(detail: InitErrorDetails) -> str:
    kind = detail["type"]
    message = kind.message() if isinstance(kind, PydanticCustomError) else str(kind)
    return f"{_fmt(detail['loc'])}: {message}" if detail["loc"] else message


def relocated(errors: Sequence[ErrorDetails], prefix: Loc = ()) -> list[InitErrorDetails]:
    """Pydantic errors as details to raise again under ``prefix``, keeping type and message."""
    out: list[InitErrorDetails] = []
    for err in errors:
        out.append(InitErrorDetails(
            type=PydanticCustomError(err["type"], err["msg"]),
            loc=(*prefix, *err["loc"]),
            input=err.get("input"),
        ))
    return out


def _shape_problems(spec: NodeType, node: Mapping[str, Any]) -> list[InitErrorDetails]:
    has_children = node.get("children") is not None
    has_child = node.get("child") is not None
    name = spec.name
    out: list[InitErrorDetails] = []
    if spec.kind == "composite":
        if has_child:
            out.append(_detail("node_shape", f"{name} takes a list of 'children', not one 'child'",
                               ("child",), node.get("child")))
        children = node.get("children")
        if not has_children and not has_child:
            out.append(_detail("node_shape", f"{name} needs 'children' (a list of nodes)",
                               ("children",), None))
        elif isinstance(children, list) and not children:
            out.append(_detail("node_shape", f"{name} needs at least one child",
                               ("children",), children))
    elif spec.kind == "decorator":
        if has_children:
            out.append(_detail("node_shape",
                               f"{name} is a decorator: give it one 'child', not 'children'",
                               ("children",), node.get("children")))
        elif not has_child:
            out.append(_detail("node_shape", f"{name} is a decorator: it needs one 'child' node",
                               ("child",), None))
    else:
        for key in ("children", "child"):
            if node.get(key) is not None:
                out.append(_detail("node_shape",
                                   f"{name} is a behaviour (a leaf): it takes no '{key}'",
                                   (key,), node.get(key)))
    return out


def _params_problems(spec: NodeType, params: Mapping[str, Any]) -> list[InitErrorDetails]:
    return model_problems(spec.params_model, params, ("params",), owner=spec.name)


def model_problems(
    model: type[BaseModel], data: Any, prefix: Loc = (), *, owner: str | None = None
) -> list[InitErrorDetails]:
    """Problems of ``data`` as ``model``, located under ``prefix``. Unknown keys get a
    did-you-mean against ``model``'s own fields (error type :data:`UNKNOWN_KEY`); ``owner``
    names the node type in the hint ("Retry takes: num_failures")."""
    try:
        model.model_validate(data)
    except ValidationError as exc:
        known = [info.alias or name for name, info in model.model_fields.items()]
        out: list[InitErrorDetails] = []
        for err in exc.errors(include_url=False):
            loc: Loc = (*prefix, *err["loc"])
            if err["type"] == "extra_forbidden" and err["loc"]:
                key = str(err["loc"][-1])
                close = difflib.get_close_matches(key, known, n=1)
                if close:
                    hint = f"; did you mean {close[0]!r}?"
                elif known:
                    listed = ", ".join(sorted(known))
                    hint = f" ({owner} takes: {listed})" if owner else f" (allowed: {listed})"
                else:
                    hint = f" ({owner} takes no params)" if owner else ""
                out.append(_detail(UNKNOWN_KEY, f"unknown key {key!r}{hint}", loc, err["input"]))
            else:
                message = err["msg"].removeprefix("Value error, ")
                out.append(_detail(err["type"], message, loc, err.get("input")))
        return out
    return []


def _fmt(loc: Sequence[str | int]) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else ("." if out else "") + str(part)
    return out


# --------------------------------------------------------------------------------------------
# Building a py_trees tree
# --------------------------------------------------------------------------------------------


def build_tree(
    node: TreeNode,
    registry: NodeRegistry,
    context: BuildContext | None = None,
    *,
    loc: Loc = ("tree",),
) -> Behaviour:
    """Instantiate the py_trees (sub)tree described by ``node``.

    The spec is checked again against ``registry`` (it may have been built in code, or loaded
    with another registry); problems raise :class:`InputErrors` located in the mission file when
    ``context.mission`` has one. ``loc`` is where ``node`` sits in the mission (for messages).
    """
    context = context or BuildContext()
    problems = registry.check(node.model_dump())
    if problems:
        raise _located(problems, loc, context)
    spec = registry.get(node.type)
    name = node.name or node.type
    params = spec.params_model.model_validate(node.params)
    if spec.kind == "composite":
        children = [
            build_tree(c, registry, context, loc=(*loc, "children", i))
            for i, c in enumerate(node.children or [])
        ]
        return _make(spec, loc, context, name, children, node, context)
    if spec.kind == "decorator":
        assert node.child is not None  # checked above
        child = build_tree(node.child, registry, context, loc=(*loc, "child"))
        return _make(spec, loc, context, name, child, params, context)
    return _make(spec, loc, context, name, params, context)


def _make(spec: NodeType, loc: Loc, context: BuildContext, *args: Any) -> Behaviour:
    """``spec.factory(*args)``; a factory's InputError or ValueError without a place in the file
    (a plugin's own check, say) is located at the node."""
    try:
        node = spec.factory(*args)
    except InputError as exc:
        if exc.file is not None:
            raise
        message = exc.message.removeprefix(f"{spec.name}: ")
        raise _located([_detail("node_build", f"{spec.name}: {message}", (), None)], loc,
                       context) from None
    except (ValueError, TypeError) as exc:
        raise _located([_detail("node_build", f"{spec.name}: {exc}", (), None)], loc,
                       context) from None
    if not isinstance(node, Behaviour):
        raise _located([_detail(
            "node_build", f"{spec.name}: the factory returned {type(node).__name__}, not a "
            "py_trees Behaviour", (), None)], loc, context)
    return node


def _located(problems: list[InitErrorDetails], loc: Loc, context: BuildContext) -> InputErrors:
    doc: YamlDocument | None = context.mission.document if context.mission is not None else None
    errors: list[InputError] = []
    for p in problems:
        full: Loc = (*loc, *p["loc"])
        kind = p["type"]
        message = kind.message() if isinstance(kind, PydanticCustomError) else str(kind)
        pos = doc.position(full) if doc is not None else None
        errors.append(InputError(
            message,
            file=doc.path if doc is not None else None,
            line=pos.line if pos else None,
            column=pos.column if pos else None,
            field=_fmt(full),
        ))
    return InputErrors(errors)
