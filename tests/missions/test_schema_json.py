"""``marknav schema``: the JSON Schema editors use to complete and check mission files."""

from __future__ import annotations

import json
from typing import Any

import pytest

from marknav.cli.main import main
from marknav.missions.schema import mission_json_schema


@pytest.fixture(scope="module")
def schema() -> dict[str, Any]:
    return mission_json_schema()


def test_schema_command_prints_the_schema(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["schema"]) == 0
    out = capsys.readouterr()
    printed = json.loads(out.out)
    assert out.err == ""
    assert printed == json.loads(json.dumps(mission_json_schema()))
    assert printed["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    assert printed["title"] == "marknav mission"
    assert {"route", "marks"} <= set(printed["properties"])
    assert printed["required"] == ["name", "marks", "route"]


def _objects(node: Any, path: str = "#") -> list[tuple[str, dict[str, Any]]]:
    """Every schema object with ``properties`` inside ``node``."""
    found: list[tuple[str, dict[str, Any]]] = []
    if isinstance(node, dict):
        if "properties" in node and isinstance(node["properties"], dict) and node["properties"]:
            found.append((path, node))
        for key, value in node.items():
            found.extend(_objects(value, f"{path}/{key}"))
    elif isinstance(node, list):
        for i, value in enumerate(node):
            found.extend(_objects(value, f"{path}/{i}"))
    return found


def test_every_key_has_a_description_and_unknown_keys_are_refused(schema: dict[str, Any]) -> None:
    objects = _objects(schema)
    assert len(objects) > 15
    for path, obj in objects:
        if path.endswith(("/if", "/then")):
            continue  # the if/then clauses of a node type, not models
        for key, prop in obj["properties"].items():
            # pydantic leaves out a field's description when it repeats its model's docstring.
            ref = prop.get("$ref", "").removeprefix("#/$defs/")
            description = prop.get("description") or schema["$defs"].get(ref, {}).get(
                "description")
            assert description, f"{path}/properties/{key} has no description"
        assert obj.get("additionalProperties") is False, path


def test_limits_and_choices_reach_the_editor(schema: dict[str, Any]) -> None:
    defs = schema["$defs"]
    assert defs["Robot"]["properties"]["max_speed_mm_s"]["maximum"] == 500
    assert defs["Robot"]["properties"]["model"]["enum"] == ["create1", "create2"]
    assert defs["ColourSpec"]["properties"]["side"]["enum"] == ["left", "right"]
    hue = defs["ColourSpec"]["properties"]["hue"]["prefixItems"][0]
    assert (hue["minimum"], hue["maximum"]) == (0, 179)
    rate = defs["Control"]["properties"]["rate_hz"]
    assert (rate["minimum"], rate["maximum"]) == (1, 100)
    assert defs["Camera"]["properties"]["range"]["discriminator"]["propertyName"] == "model"


def test_tree_node_types_and_their_params(schema: dict[str, Any]) -> None:
    node = schema["$defs"]["TreeNode"]
    assert {"Sequence", "Selector", "Parallel", "Retry", "Timeout", "Pause"} <= set(
        node["properties"]["type"]["examples"])
    clauses = {c["if"]["properties"]["type"]["const"]: c["then"] for c in node["allOf"]}
    assert clauses["Sequence"]["required"] == ["memory", "children"]
    assert clauses["Parallel"]["required"] == ["policy", "children"]
    assert clauses["Retry"]["required"] == ["child"]
    retry = clauses["Retry"]["properties"]["params"]
    assert retry["required"] == ["num_failures"]
    assert retry["properties"]["num_failures"]["minimum"] == 1
    assert retry["additionalProperties"] is False
    assert "required" not in clauses["Pause"]
    assert clauses["Pause"]["properties"]["params"]["required"] == ["seconds"]
