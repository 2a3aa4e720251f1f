"""Generated missions for MuJoCo: the same course as the built-in engine's, in a full room
(lamps, textures, occluders, distractors, turned marks) drawn clear of every mark."""

from __future__ import annotations

import math

import pytest

from marknav.runs.evaluation.random_mission import random_mission, write_random_mission
from marknav.runs.records.seed_result import replay_command
from marknav.sim.randomisation import bounds

SEEDS = range(6)


@pytest.mark.parametrize("seed", SEEDS)
def test_the_mujoco_mission_has_the_builtin_course_in_a_full_room(seed: int) -> None:
    plain, full = random_mission(seed), random_mission(seed, "mujoco")
    assert plain.world.mujoco is None and plain.mission.sim is not None
    assert plain.mission.sim.engine == "builtin"
    assert full.mission.sim is not None and full.mission.sim.engine == "mujoco"
    assert full.mission.route == plain.mission.route
    assert full.mission.navigation == plain.mission.navigation
    assert [m.xy for m in full.world.marks] == [m.xy for m in plain.world.marks]
    scene = full.world.mujoco
    assert scene is not None and scene.lights and scene.distractors is not None
    # nothing of the room stands within the lane of any mark, off-course marks included
    p0 = full.world.robot.pose()
    reach = full.mission.navigation.clearance_mm + full.mission.robot.radius_mm
    for thing in (*scene.occluders, *scene.distractors):
        for m in full.world.marks:
            assert math.hypot(thing.x_mm - (m.x_mm - p0.x), thing.y_mm - (m.y_mm - p0.y)) > reach


def test_mujoco_marks_are_turned_by_mujocos_wider_range() -> None:
    assert bounds("mujoco.mark_yaw")[1] > bounds("builtin.mark_yaw")[1]
    for s in SEEDS:
        assert [m.yaw_deg for m in random_mission(s, "mujoco").world.marks] != \
            [m.yaw_deg for m in random_mission(s).world.marks]


def test_its_files_and_replay_name_the_engine(tmp_path) -> None:
    mission_path, world_path = write_random_mission(3, tmp_path, "mujoco")
    assert "engine: mujoco" in mission_path.read_text(encoding="utf-8")
    assert "mujoco:" in world_path.read_text(encoding="utf-8")
    assert replay_command("random", 3, engine="mujoco") == (
        "marknav random-mission --seed 3 --engine mujoco --out runs/random-3 && marknav run "
        "runs/random-3/mission.yaml --seed 3 --engine mujoco")
