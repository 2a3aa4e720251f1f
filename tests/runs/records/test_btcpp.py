"""The BehaviorTree.CPP XML export: every shipped example loads in a real BehaviorTree.CPP (the
behaviortreepy bindings) with marknav's node types registered from the file's own
<TreeNodesModel>, validates against the schema BehaviorTree.CPP's writeTreeXSD writes, and
reads back with the same nodes, names and uids."""

from __future__ import annotations

import socket
import struct

import py_trees
import pytest

from marknav.behaviours.pause import Pause, Timeout
from marknav.behaviours.tree import build_mission_tree
from marknav.missions.examples import example_names, mission_path
from marknav.runs.loop.checks import checked_mission
from marknav.runs.records.btcpp import (
    BUILTINS,
    nodes_of,
    read_tree_xml,
    tree_xml,
    tree_xsd,
    used_models,
)
from marknav.runs.records.tree_state import TreeState

bt = pytest.importorskip("behaviortreepy")
etree = pytest.importorskip("lxml.etree")

EXAMPLES = example_names()


def _tree(name: str) -> py_trees.behaviour.Behaviour:
    return build_mission_tree(checked_mission(mission_path(name), {}))


def _factory_from_models(xml: str) -> object:
    """A BehaviorTree.CPP factory with every non-builtin type of the file's TreeNodesModel
    registered (behaviortreepy registers simple nodes without ports)."""
    factory = bt.BehaviorTreeFactory()
    for node_id, category in read_tree_xml(xml)["models"].items():
        if node_id in BUILTINS:
            continue
        if category == "Condition":
            factory.register_simple_condition(node_id, lambda node: bt.NodeStatus.SUCCESS)
        elif category == "Decorator":
            factory.register_simple_decorator(node_id, lambda status, node: status)
        else:
            assert category == "Action", (node_id, category)
            factory.register_simple_action(node_id, lambda node: bt.NodeStatus.SUCCESS)
    return factory


def _free_port_pair() -> int:
    """A TCP port P with P + 1 free too (Groot2's server and its publisher)."""
    for _ in range(50):
        with socket.socket() as a:
            a.bind(("127.0.0.1", 0))
            port = a.getsockname()[1]
            with socket.socket() as b:
                try:
                    b.bind(("127.0.0.1", port + 1))
                except OSError:
                    continue
        return int(port)
    raise RuntimeError("no two free ports in a row")


def _btcpp_tree_xml(tree: object) -> str:
    """The tree as BehaviorTree.CPP itself writes it for Groot2 (its publisher's T reply)."""
    zmq = pytest.importorskip("zmq")
    port = _free_port_pair()
    publisher = bt.Groot2Publisher(tree, port)
    ctx = zmq.Context()
    try:
        sock = ctx.socket(zmq.REQ)
        sock.setsockopt(zmq.RCVTIMEO, 5000)
        sock.setsockopt(zmq.LINGER, 0)
        sock.connect(f"tcp://127.0.0.1:{port}")
        sock.send(struct.pack("<BBI", 2, ord("T"), 7))
        reply = sock.recv_multipart()
        sock.close()
    finally:
        ctx.term()
        del publisher
    return bytes(reply[1]).decode()


def test_examples_are_shipped() -> None:
    assert "slalom" in EXAMPLES and len(EXAMPLES) >= 5


@pytest.mark.parametrize("name", EXAMPLES)
def test_every_example_loads_in_behaviortree_cpp_with_the_same_nodes(name: str) -> None:
    root = _tree(name)
    state = TreeState.of_tree(root)
    xml = tree_xml(root, name)
    factory = _factory_from_models(xml)
    tree = factory.create_tree_from_text(xml)  # raises on an unknown type or port
    ours = read_tree_xml(xml)
    assert ours["names"] == state.names
    assert ours["uids"] == list(range(1, len(state.names) + 1))
    assert ours["parents"] == state.parents
    # BehaviorTree.CPP numbers the nodes it created itself: its Groot2 server's tree has the
    # same nodes, names, types and uids as the file.
    theirs = read_tree_xml(_btcpp_tree_xml(tree))
    for key in ("names", "uids", "parents", "tags"):
        assert theirs[key] == ours[key], key


@pytest.mark.parametrize("name", EXAMPLES)
def test_every_example_is_valid_against_the_btcpp_schema(name: str) -> None:
    nodes = nodes_of(_tree(name))
    schema = etree.XMLSchema(etree.fromstring(
        tree_xsd([*BUILTINS.values(), *used_models(nodes)]).encode()))
    plain = etree.fromstring(tree_xml(nodes, name, metadata=False).encode())
    assert schema.validate(plain), schema.error_log
    # The uids Groot2 needs are metadata BehaviorTree.CPP's own schema does not admit: the
    # file with them differs from the valid one by those attributes only.
    with_uids = etree.fromstring(tree_xml(nodes, name).encode())
    for el in with_uids.iter():
        el.attrib.pop("_uid", None)
        el.attrib.pop("_fullpath", None)
    assert etree.tostring(with_uids) == etree.tostring(plain)


def test_the_schema_rejects_a_tree_that_breaks_it() -> None:
    nodes = nodes_of(_tree("slalom"))
    schema = etree.XMLSchema(etree.fromstring(
        tree_xsd([*BUILTINS.values(), *used_models(nodes)]).encode()))
    bad = tree_xml(nodes, "slalom", metadata=False).replace("<Perception ", "<Perceptio ", 1)
    assert not schema.validate(etree.fromstring(bad.encode()))


def test_node_types_map_to_btcpp_ones_with_their_ports() -> None:
    child = py_trees.behaviours.Success(name="ok")
    root = py_trees.composites.Sequence("S", memory=False, children=[
        py_trees.decorators.Retry("R", py_trees.behaviours.Failure(name="no"), num_failures=3),
        py_trees.decorators.Repeat("Rp", Pause(name="wait", seconds=1.5), num_success=-1),
        Timeout(name="T", child=child, duration=2.0),
        py_trees.composites.Selector("F", memory=True, children=[
            py_trees.behaviours.Running(name="run")]),
    ])
    xml = tree_xml(root, "Main")
    back = read_tree_xml(xml)
    assert back["tags"] == ["ReactiveSequence", "RetryUntilSuccessful", "AlwaysFailure",
                            "Repeat", "Sleep", "Timeout", "AlwaysSuccess", "Fallback",
                            "Running"]
    assert 'num_attempts="3"' in xml and 'num_cycles="-1"' in xml
    assert 'msec="1500"' in xml and 'msec="2000"' in xml
    assert back["models"] == {"Running": "Action"}  # BT.CPP's own types are not declared
    tree = _factory_from_models(xml).create_tree_from_text(xml)
    assert tree.tick_while_running() == bt.NodeStatus.FAILURE  # retries, then fails


def test_marknav_types_declare_their_blackboard_keys_as_ports() -> None:
    xml = tree_xml(_tree("slalom"), "slalom")
    doc = etree.fromstring(xml.encode())
    model = doc.find("TreeNodesModel/Action[@ID='SelectTarget']")
    assert model is not None
    ports = {(p.tag, p.get("name")) for p in model}
    assert ("output_port", "target") in ports and ("input_port", "marks") in ports
    assert doc.find("TreeNodesModel/Condition[@ID='TargetSeen']") is not None
    assert doc.find("TreeNodesModel/Action[@ID='BezierBypass']") is not None
