"""A py_trees tree as BehaviorTree.CPP v4 XML, the format Groot2 draws, monitors and replays.

BehaviorTree.CPP (BT.CPP) numbers a tree's nodes as it creates them from its XML: pre-order,
from 1 (``Tree::getUID``). Groot2 speaks of nodes only by these uids (``_uid`` in the XML its
monitor and its ``.btlog`` files carry; status records name nodes by uid), so a marknav node's
uid is its pre-order index + 1 — the index the run log and :class:`TreeState` use, plus one.

Each py_trees node becomes the BT.CPP node that behaves the same, where there is one:

=========================================  ============================================
py_trees / marknav                          BT.CPP 4
=========================================  ============================================
``Sequence(memory=True)``                   ``Sequence`` (resumes at its running child)
``Sequence(memory=False)``                  ``ReactiveSequence`` (starts again every tick)
``Selector(memory=True / False)``           ``Fallback`` / ``ReactiveFallback``
``Parallel`` success on all / on one        ``Parallel`` ``success_count`` -1 / 1
``Inverter``, ``SuccessIsFailure``,         ``Inverter``, ``ForceFailure``, ``ForceSuccess``
``FailureIsSuccess``
``Retry(num_failures)``                     ``RetryUntilSuccessful(num_attempts)``
``Repeat(num_success)``                     ``Repeat(num_cycles)``
``Timeout(duration)``, ``Pause(seconds)``   ``Timeout(msec)``, ``Sleep(msec)`` (mission time)
``Success``, ``Failure``                    ``AlwaysSuccess``, ``AlwaysFailure``
=========================================  ============================================

Every other node is a node type of marknav's (or of a user's plugin), named after its class and
declared in the ``<TreeNodesModel>``: a decorator or composite as ``Decorator``/``Control``, a
marknav behaviour that neither drives nor writes to the blackboard as a ``Condition`` (it only
looks), any other leaf as an ``Action``. A marknav behaviour's ports are its blackboard keys
(``READS``: ``input_port``; ``WRITES``, which marknav's writers also read: ``output_port`` —
BT.CPP's schema admits no ``inout_port`` in a model), named after the key without
``/marknav/`` and defaulting to the blackboard entry ``{name}``, so the instances need no port
attributes and load in a BT.CPP whose node types were registered without ports, as the Python
bindings of BT.CPP register simple actions.

:func:`tree_xsd` writes the XML schema of these node types the way BT.CPP's ``writeTreeXSD``
does. That schema admits no ``_uid`` (BT.CPP writes uids as metadata for Groot2 only), so a
file to validate is written with ``metadata=False``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import Any, Literal

import py_trees
from py_trees.behaviour import Behaviour

from marknav.behaviours import keys
from marknav.behaviours.base import DrivingBehaviour, MarknavBehaviour
from marknav.behaviours.pause import Pause, Timeout
from marknav.runs.records.tree_state import TreeState, _preorder

Category = Literal["Action", "Condition", "Control", "Decorator"]
Direction = Literal["input_port", "output_port", "inout_port"]

#: Milliseconds a second: BT.CPP's Timeout and Sleep take ``msec``.
MS_PER_S = 1000.0


@dataclass(frozen=True)
class Port:
    """A port of a node type, as ``<TreeNodesModel>`` declares it."""

    name: str
    direction: Direction
    type: str | None = None
    default: str | None = None
    description: str = ""


@dataclass(frozen=True)
class NodeModel:
    """A node type: BT.CPP's registration ID, its category and ports; ``builtin``: one of
    BT.CPP's own (every BT.CPP knows it, so no model needs declaring)."""

    id: str
    category: Category
    ports: tuple[Port, ...] = ()
    builtin: bool = False
    description: str = ""


@dataclass
class BtNode:
    """One node of the exported tree: its type, its name and its port values."""

    model: NodeModel
    name: str
    attributes: dict[str, str] = field(default_factory=dict)
    parent: int = -1


def _builtin(id_: str, category: Category, *ports: Port) -> NodeModel:
    return NodeModel(id_, category, tuple(ports), builtin=True)


def _int_port(name: str, default: str | None, what: str) -> Port:
    return Port(name, "input_port", "int", default, what)


#: The BT.CPP 4 node types the export uses, with their ports as BT.CPP 4.10 declares them.
BUILTINS: dict[str, NodeModel] = {m.id: m for m in (
    _builtin("Sequence", "Control"),
    _builtin("ReactiveSequence", "Control"),
    _builtin("Fallback", "Control"),
    _builtin("ReactiveFallback", "Control"),
    _builtin("Parallel", "Control",
             _int_port("failure_count", "1", "number of children that need to fail to "
                       "trigger a FAILURE"),
             _int_port("success_count", "-1", "number of children that need to succeed to "
                       "trigger a SUCCESS")),
    _builtin("Inverter", "Decorator"),
    _builtin("ForceSuccess", "Decorator"),
    _builtin("ForceFailure", "Decorator"),
    _builtin("RetryUntilSuccessful", "Decorator",
             _int_port("num_attempts", None, "Execute again a failing child up to N times. "
                       "Use -1 to create an infinite loop.")),
    _builtin("Repeat", "Decorator",
             _int_port("num_cycles", None, "Repeat a successful child up to N times. Use -1 "
                       "to create an infinite loop.")),
    _builtin("Timeout", "Decorator",
             Port("msec", "input_port", "unsigned int", None,
                  "After a certain amount of time, halt() the child if it is still running.")),
    _builtin("Sleep", "Action", Port("msec", "input_port", "unsigned int")),
    _builtin("AlwaysSuccess", "Action"),
    _builtin("AlwaysFailure", "Action"),
)}


def _ms(seconds: float) -> str:
    return str(round(seconds * MS_PER_S))


def _composite(node: Behaviour) -> tuple[NodeModel, dict[str, str]] | None:
    if isinstance(node, py_trees.composites.Sequence):
        return BUILTINS["Sequence" if node.memory else "ReactiveSequence"], {}
    if isinstance(node, py_trees.composites.Selector):
        return BUILTINS["Fallback" if node.memory else "ReactiveFallback"], {}
    if isinstance(node, py_trees.composites.Parallel):
        policy = node.policy
        if isinstance(policy, py_trees.common.ParallelPolicy.SuccessOnAll):
            return BUILTINS["Parallel"], {"success_count": "-1", "failure_count": "1"}
        if isinstance(policy, py_trees.common.ParallelPolicy.SuccessOnOne):
            return BUILTINS["Parallel"], {"success_count": "1", "failure_count": "1"}
    return None


def _decorator(node: Behaviour) -> tuple[NodeModel, dict[str, str]] | None:
    d = py_trees.decorators
    plain: dict[type[Behaviour], str] = {d.Inverter: "Inverter",
                                         d.SuccessIsFailure: "ForceFailure",
                                         d.FailureIsSuccess: "ForceSuccess"}
    if type(node) in plain:
        return BUILTINS[plain[type(node)]], {}
    if type(node) is d.Retry:
        return BUILTINS["RetryUntilSuccessful"], {"num_attempts": str(node.num_failures)}
    if type(node) is d.Repeat:
        return BUILTINS["Repeat"], {"num_cycles": str(node.num_success)}
    if isinstance(node, Timeout):
        return BUILTINS["Timeout"], {"msec": _ms(node.duration)}
    return None


def _leaf(node: Behaviour) -> tuple[NodeModel, dict[str, str]] | None:
    if isinstance(node, Pause):
        return BUILTINS["Sleep"], {"msec": _ms(node.seconds)}
    if type(node) is py_trees.behaviours.Success:
        return BUILTINS["AlwaysSuccess"], {}
    if type(node) is py_trees.behaviours.Failure:
        return BUILTINS["AlwaysFailure"], {}
    return None


def _port_name(key: str) -> str:
    """A blackboard key as a port name: ``/marknav/target`` -> ``target``."""
    prefix = keys.NAMESPACE + "/"
    return (key[len(prefix):] if key.startswith(prefix) else key.strip("/")).replace("/", "_")


def _ports(cls: type[Behaviour]) -> tuple[Port, ...]:
    if not issubclass(cls, MarknavBehaviour):
        return ()
    reads, writes = set(cls.READS), set(cls.WRITES)
    out = []
    for key in sorted(reads | writes):
        direction: Direction = "output_port" if key in writes else "input_port"
        name = _port_name(key)
        out.append(Port(name, direction, default="{" + name + "}",
                        description=f"blackboard {key}"))
    return tuple(out)


def _description(cls: type[Behaviour]) -> str:
    doc = (cls.__doc__ or "").strip()
    return doc.split("\n\n", 1)[0].replace("\n", " ") if doc else ""


def model_of(node: Behaviour) -> tuple[NodeModel, dict[str, str]]:
    """The BT.CPP node type of a py_trees node and its port values."""
    for known in (_composite, _decorator, _leaf):
        found = known(node)
        if found is not None:
            return found
    cls = type(node)
    category: Category
    if isinstance(node, py_trees.composites.Composite):
        category = "Control"
    elif isinstance(node, py_trees.decorators.Decorator):
        category = "Decorator"
    elif (isinstance(node, MarknavBehaviour) and not isinstance(node, DrivingBehaviour)
          and not node.WRITES):
        category = "Condition"
    else:
        category = "Action"
    name = cls.__name__ if cls.__name__ not in BUILTINS else f"{cls.__module__}.{cls.__name__}"
    return NodeModel(name.replace(".", "_"), category, _ports(cls),
                     description=_description(cls)), {}


def nodes_of(root: Behaviour) -> list[BtNode]:
    """The tree as BT.CPP nodes, in pre-order (node ``i`` has uid ``i + 1``)."""
    tree = _preorder(root)
    index = {id(n): i for i, n in enumerate(tree)}
    out = []
    for n in tree:
        model, attributes = model_of(n)
        out.append(BtNode(model, n.name, attributes,
                          index[id(n.parent)] if n.parent is not None else -1))
    return out


#: BT.CPP types for a tree known only from a run log's shape (a log written before the XML
#: was kept): composites and decorators by kind and memory, leaves as one generic action.
_BY_KIND = {("sequence", True): "Sequence", ("sequence", False): "ReactiveSequence",
            ("selector", True): "Fallback", ("selector", False): "ReactiveFallback"}
_GENERIC = {"parallel": NodeModel("Parallel_", "Control"),
            "decorator": NodeModel("Decorator_", "Decorator"),
            "leaf": NodeModel("Behaviour", "Action")}


def nodes_of_state(state: TreeState) -> list[BtNode]:
    """The BT.CPP nodes of a tree known only by its shape (names, kinds, memory)."""
    out = []
    for i, name in enumerate(state.names):
        kind = state.kinds[i]
        builtin = _BY_KIND.get((kind, state.memory[i]))
        model = BUILTINS[builtin] if builtin else _GENERIC[kind]
        out.append(BtNode(model, name, {}, state.parents[i]))
    return out


def tree_xml(nodes: list[BtNode] | Behaviour, tree_id: str = "MainTree", *,
             metadata: bool = True, builtin_models: bool = False) -> str:
    """BT.CPP 4 XML of the tree: ``<BehaviorTree ID=tree_id>`` and a ``<TreeNodesModel>`` of the
    node types it uses; ``metadata``: ``_uid`` on every node (and ``_fullpath``) as BT.CPP's
    ``WriteTreeToXML`` writes them for Groot2; ``builtin_models``: declare BT.CPP's own types
    too (Groot2's monitor receives them so)."""
    if isinstance(nodes, Behaviour):
        nodes = nodes_of(nodes)
    root = ET.Element("root", BTCPP_format="4", main_tree_to_execute=tree_id)
    bt = ET.SubElement(root, "BehaviorTree", ID=tree_id)
    if metadata:
        bt.set("_fullpath", "")
    elements: list[ET.Element] = []
    for uid, node in enumerate(nodes, start=1):
        parent = bt if node.parent < 0 else elements[node.parent]
        el = ET.SubElement(parent, node.model.id, name=node.name)
        if metadata:
            el.set("_uid", str(uid))
        for key, value in node.attributes.items():
            el.set(key, value)
        elements.append(el)
    models = ET.SubElement(root, "TreeNodesModel")
    for model in used_models(nodes, builtin=builtin_models):
        models.append(_model_element(model))
    ET.indent(root, space="    ")
    return ET.tostring(root, encoding="unicode") + "\n"


def used_models(nodes: list[BtNode], *, builtin: bool = True) -> list[NodeModel]:
    """The node types the tree uses, sorted by ID (as BT.CPP orders its models)."""
    found = {n.model.id: n.model for n in nodes if builtin or not n.model.builtin}
    return [found[k] for k in sorted(found)]


def _model_element(model: NodeModel) -> ET.Element:
    el: ET.Element = ET.Element(str(model.category), ID=model.id)
    for port in model.ports:
        p = ET.SubElement(el, port.direction, name=port.name)
        if port.type is not None:
            p.set("type", port.type)
        if port.default is not None and port.direction == "input_port":
            p.set("default", port.default)  # BT.CPP's schema has no default on an output
        if port.description:
            p.text = port.description
    return el


# --- the schema -----------------------------------------------------------------------------

_XS = "http://www.w3.org/2001/XMLSchema"

#: The common part of BT.CPP 4.10's ``writeTreeXSD`` (its fixed text, the same element order).
_XSD_COMMON = """
<xs:simpleType name="blackboardType"><xs:restriction base="xs:string">
  <xs:pattern value="\\{.*\\}"/></xs:restriction></xs:simpleType>
<xs:simpleType name="booleanOrBlackboardType">
  <xs:union memberTypes="xs:boolean blackboardType"/></xs:simpleType>
<xs:simpleType name="integerOrBlackboardType">
  <xs:union memberTypes="xs:integer blackboardType"/></xs:simpleType>
<xs:simpleType name="decimalOrBlackboardType">
  <xs:union memberTypes="xs:decimal blackboardType"/></xs:simpleType>
<xs:simpleType name="stringOrBlackboardType">
  <xs:union memberTypes="xs:string blackboardType"/></xs:simpleType>
<xs:simpleType name="descriptionType"><xs:restriction base="xs:string">
  <xs:whiteSpace value="preserve"/></xs:restriction></xs:simpleType>
<xs:complexType name="inputPortType"><xs:simpleContent><xs:extension base="xs:string">
  <xs:attribute name="name" type="xs:string" use="required"/>
  <xs:attribute name="type" type="xs:string" use="optional"/>
  <xs:attribute name="default" type="xs:string" use="optional"/>
</xs:extension></xs:simpleContent></xs:complexType>
<xs:complexType name="outputPortType"><xs:simpleContent><xs:extension base="xs:string">
  <xs:attribute name="name" type="xs:string" use="required"/>
  <xs:attribute name="type" type="xs:string" use="optional"/>
</xs:extension></xs:simpleContent></xs:complexType>
<xs:attributeGroup name="preconditionAttributeGroup">
  <xs:attribute name="_failureIf" type="xs:string" use="optional"/>
  <xs:attribute name="_skipIf" type="xs:string" use="optional"/>
  <xs:attribute name="_successIf" type="xs:string" use="optional"/>
  <xs:attribute name="_while" type="xs:string" use="optional"/>
</xs:attributeGroup>
<xs:attributeGroup name="postconditionAttributeGroup">
  <xs:attribute name="_onSuccess" type="xs:string" use="optional"/>
  <xs:attribute name="_onFailure" type="xs:string" use="optional"/>
  <xs:attribute name="_post" type="xs:string" use="optional"/>
  <xs:attribute name="_onHalted" type="xs:string" use="optional"/>
</xs:attributeGroup>
<xs:attributeGroup name="commonAttributeGroup">
  <xs:attribute name="name" type="xs:string" use="optional"/>
  <xs:attributeGroup ref="preconditionAttributeGroup"/>
  <xs:attributeGroup ref="postconditionAttributeGroup"/>
</xs:attributeGroup>
<xs:complexType name="treeNodesModelNodeType"><xs:sequence>
  <xs:choice minOccurs="0" maxOccurs="unbounded">
    <xs:element name="input_port" type="inputPortType"/>
    <xs:element name="output_port" type="outputPortType"/>
  </xs:choice>
  <xs:element name="description" type="descriptionType" minOccurs="0" maxOccurs="1"/>
</xs:sequence><xs:attribute name="ID" type="xs:string" use="required"/></xs:complexType>
<xs:group name="treeNodesModelNodeGroup"><xs:choice>
  <xs:element name="Action" type="treeNodesModelNodeType"/>
  <xs:element name="Condition" type="treeNodesModelNodeType"/>
  <xs:element name="Control" type="treeNodesModelNodeType"/>
  <xs:element name="Decorator" type="treeNodesModelNodeType"/>
</xs:choice></xs:group>
<xs:element name="root"><xs:complexType><xs:sequence>
  <xs:choice minOccurs="0" maxOccurs="unbounded">
    <xs:element ref="include"/><xs:element ref="BehaviorTree"/></xs:choice>
  <xs:element ref="TreeNodesModel" minOccurs="0" maxOccurs="1"/></xs:sequence>
  <xs:attribute name="BTCPP_format" type="xs:string" use="required"/>
  <xs:attribute name="main_tree_to_execute" type="xs:string" use="optional"/>
</xs:complexType></xs:element>
"""

_XSD_TAIL = """
<xs:element name="include"><xs:complexType>
  <xs:attribute name="path" type="xs:string" use="required"/>
  <xs:attribute name="ros_pkg" type="xs:string" use="optional"/></xs:complexType></xs:element>
<xs:element name="BehaviorTree"><xs:complexType><xs:group ref="oneNodeGroup"/>
  <xs:attribute name="ID" type="xs:string" use="required"/></xs:complexType></xs:element>
<xs:element name="TreeNodesModel"><xs:complexType>
  <xs:group ref="treeNodesModelNodeGroup" minOccurs="0" maxOccurs="unbounded"/>
</xs:complexType></xs:element>
"""

#: BT.CPP's ``xsdAttributeType``: a port's C++ type as the XSD type of its attribute.
_XSD_TYPES = {"bool": "booleanOrBlackboardType", "int": "integerOrBlackboardType",
              "unsigned int": "integerOrBlackboardType", "double": "decimalOrBlackboardType",
              "float": "decimalOrBlackboardType", "std::string": "stringOrBlackboardType"}


def tree_xsd(models: list[NodeModel]) -> str:
    """The XML schema BT.CPP's ``writeTreeXSD`` writes for a factory holding ``models``."""
    ordered = sorted({m.id: m for m in models}.values(), key=lambda m: m.id)
    parts = [f'<xs:schema xmlns:xs="{_XS}" elementFormDefault="qualified">', _XSD_COMMON,
             '<xs:group name="oneNodeGroup"><xs:choice>']
    parts += [f'<xs:element name="{m.id}" type="{m.id}Type"/>' for m in ordered]
    parts += ["</xs:choice></xs:group>", _XSD_TAIL]
    for m in ordered:
        parts.append(f'<xs:complexType name="{m.id}Type">')
        if m.category == "Decorator":
            parts.append('<xs:group ref="oneNodeGroup" minOccurs="1" maxOccurs="1"/>')
        elif m.category == "Control":
            parts.append('<xs:group ref="oneNodeGroup" minOccurs="0" maxOccurs="unbounded"/>')
        parts.append('<xs:attributeGroup ref="commonAttributeGroup"/>')
        for port in m.ports:
            attrs = [f'name="{port.name}"']
            xsd_type = _XSD_TYPES.get(port.type or "")
            if xsd_type:
                attrs.append(f'type="{xsd_type}"')
            attrs.append(f'default="{_escape(port.default)}"' if port.default is not None
                         else 'use="required"')
            parts.append(f"<xs:attribute {' '.join(attrs)}/>")
        parts.append("</xs:complexType>")
    parts.append("</xs:schema>")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + "\n".join(parts) + "\n"


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")


def read_tree_xml(text: str) -> dict[str, Any]:
    """The first ``<BehaviorTree>`` of BT.CPP XML as plain data: ``tags``, ``names``, ``uids``
    and ``parents`` in pre-order, and ``models`` (ID -> category) of its ``<TreeNodesModel>``.
    :class:`ValueError` when it is not BT.CPP 4 XML."""
    root = ET.fromstring(text)
    if root.tag != "root" or root.get("BTCPP_format") != "4":
        raise ValueError("not BehaviorTree.CPP 4 XML (<root BTCPP_format=\"4\">)")
    bt = root.find("BehaviorTree")
    if bt is None or len(bt) != 1:
        raise ValueError("no <BehaviorTree> with one root node")
    tags: list[str] = []
    names: list[str] = []
    uids: list[int | None] = []
    parents: list[int] = []
    stack: list[tuple[ET.Element, int]] = [(bt[0], -1)]
    while stack:
        el, parent = stack.pop()
        i = len(tags)
        tags.append(el.tag)
        names.append(el.get("name", el.tag))
        uid = el.get("_uid")
        uids.append(int(uid) if uid is not None else None)
        parents.append(parent)
        stack.extend((child, i) for child in reversed(el))
    models = {m.get("ID", ""): m.tag for m in root.findall("TreeNodesModel/*")}
    return {"id": bt.get("ID"), "tags": tags, "names": names, "uids": uids,
            "parents": parents, "models": models}
