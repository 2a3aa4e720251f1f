"""``marknav schema --world``: generated from the World model, every key described."""

from __future__ import annotations

import json

import pytest
from pydantic import BaseModel

from marknav.cli.main import main
from marknav.sim import world as worldmod

DESCRIBED = {
    "World": {"marks", "robot", "walls", "boxes", "conditions", "background"},
    "MarkSpec": {"colour", "x_mm", "y_mm", "yaw_deg", "radius_mm"},
    "RobotStart": {"x_mm", "y_mm", "heading_deg"},
    "Wall": {"x1_mm", "y1_mm", "x2_mm", "y2_mm"},
    "Box": {"x_mm", "y_mm", "width_mm", "depth_mm", "yaw_deg"},
    "Conditions": {"lighting_gain", "cast", "noise_sigma", "blur_sigma_px", "wheel_mismatch",
                   "wheel_slip", "latency_frames"},
    "Background": {"seed", "clutter"},
}


def _sections() -> dict[str, type[BaseModel]]:
    out: dict[str, type[BaseModel]] = {"World": worldmod.World}
    for name in ("MarkSpec", "RobotStart", "Wall", "Box", "Conditions", "Background"):
        out[name] = getattr(worldmod, name)
    return out


def test_schema_follows_the_model_and_describes_every_key(
    capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["schema", "--world"]) == 0
    schema = json.loads(capsys.readouterr().out)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    assert schema["title"] == "marknav simulator world"
    defs = {"World": schema, **schema["$defs"]}
    for name, model in _sections().items():
        section = defs[name]
        # exactly the model's fields (a field added to the model shows up by itself) ...
        assert set(section["properties"]) == set(model.model_fields), name
        assert section["additionalProperties"] is False  # unknown keys are refused
        # ... each with a description (the keys of this version; a field added later needs one
        # too: Field(description=...), a "- ``key``: text" docstring line, or DESCRIPTIONS)
        missing = [k for k, p in section["properties"].items()
                   if k in DESCRIBED[name] and not p.get("description")]
        assert missing == [], f"{name}: {missing}"
    assert defs["Conditions"]["properties"]["noise_sigma"]["description"] == (
        "σ of additive Gaussian image noise, grey levels.")


def test_world_and_plugin_do_not_mix(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["schema", "--world", "--plugin", "x"]) == 2
    assert "--plugin: does not apply with --world" in capsys.readouterr().err
