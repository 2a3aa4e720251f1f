"""Random missions: a mission and its world drawn from one seed, for evaluating on missions
nobody tuned for (``marknav evaluate --missions random``, issue 11).

Per seed (deterministic: the same seed gives the same mission and world, on any machine):

- 2–5 colours from :data:`PALETTE` (red, orange, yellow, green, teal, blue, purple), each passed
  on a random side (so the sides are mixed);
- a route of 3–12 waypoints over them, with repeats and consecutive waypoints of one colour
  (:data:`REPEAT_PREVIOUS` of the time the previous colour comes again, else another one);
- mark radius 60–100 mm; clearance 250–450 mm (at least the robot radius + mark radius +
  :data:`MIN_GAP_MM`, or the robot would touch the mark); bypass distance 700–1200 mm; approach
  speed 150–300 mm/s;
- a range model: the simulator's own fit (power law, of 100 mm marks, rescaled to the mission's
  mark radius), the pinhole model, or that fit with its scale off by up to ±25 % (a range law
  that over- or under-estimates every distance by that much);
- the world: :func:`marknav.sim.world.generate.generate_world` for that route with randomised
  conditions (its course: the marks in route order), plus 0–3 off-course marks of route colours
  beside the course, placed where they are never nearer than a course mark of their colour from
  where the robot looks for it.

The ranges are the ``mission.*`` entries of the one table, :mod:`marknav.sim.randomisation`.

:func:`random_mission` gives the pair; :func:`write_random_mission` writes them as YAML
(``mission.yaml`` + ``world.yaml``) so ``marknav run DIR/mission.yaml --seed S`` replays the
evaluation's run ``S`` exactly (``marknav random-mission --seed S --out DIR``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import yaml

from marknav.core.yamlio import load_yaml_text
from marknav.missions.schema import Mission, parse_mission
from marknav.sim.randomisation import bounds, counts
from marknav.sim.world.generate import generate_world
from marknav.sim.world.schema import CREATE_RADIUS_MM, MarkSpec, World

__all__ = ["PALETTE", "RANDOM", "RandomMission", "random_mission",
           "write_random_mission"]

Side = Literal["left", "right"]

#: The mission spec that means "draw a mission per run".
RANDOM = "random"

#: Colour name → (OpenCV hue range, saturation floor), written as a user calibrates a palette: each
#: range holds the hues the camera gives its mark over the whole range of randomised light
#: (``camera.lighting_gain`` of :mod:`marknav.sim.randomisation`, every cast), after the detector's
#: white balance, and the ranges do not overlap. The simulator paints a mark the middle of its
#: range. Orange is wide and off-centre in what it holds: bright light clips its red channel, and
#: the camera reads the paint of hue 14 anywhere from 12.6 (dim, warm) to 23.8 (bright, warm). The
#: saturation floor sits between what the room reaches in a mark's own hue (floors up to
#: ``room.floor_saturation``'s 160, +8 % grain) and what the marks read (≥ 230 at the 5th
#: percentile in the dimmest, noisiest light): with a floor of 100, a near mark standing on a wood
#: floor or carpet of its hue merged with it and was not found.
#: ``tests/runs/evaluation/test_random_mission.py`` measures both. The floors are for marks of
#: full paint: a world's printed marks (``mark_saturation`` < 1) get floors scaled by the palest
#: one's.
PALETTE: dict[str, tuple[tuple[int, int], int]] = {
    "red": ((166, 2), 180),
    "orange": ((3, 25), 180),
    "yellow": ((26, 36), 180),
    "green": ((42, 80), 180),
    "teal": ((84, 98), 180),
    "blue": ((102, 128), 180),
    "purple": ((134, 162), 180),
}
# The drawn ranges are entries of the one table, marknav.sim.randomisation (``mission.*``).
COLOURS_RANGE = counts("mission.colours")
ROUTE_LENGTH_RANGE = counts("mission.route_length")
REPEAT_PREVIOUS = 0.2
RADIUS_RANGE_MM = bounds("mission.mark_radius")
CLEARANCE_RANGE_MM = bounds("mission.clearance")
MIN_GAP_MM = 45.0
BYPASS_RANGE_MM = bounds("mission.bypass_distance")
APPROACH_SPEED_RANGE_MM_S = bounds("mission.approach_speed")
#: The simulator's own fit of the default camera (``marknav calibrate --sim``; slalom.yaml).
SIM_FIT = (59385.0, -1.0013)
SIM_FIT_RADIUS_MM = 100.0
FOCAL_PX = 590.0
#: The range law's scale is off by up to this (``mission.range_scale``: 0.75-1.25).
RANGE_SCALE_ERROR = bounds("mission.range_scale")[1] - 1.0
OFF_COURSE_RANGE = counts("mission.off_course_marks")
#: Off-course marks stand this far beside the course's axis.
OFF_COURSE_LATERAL_MM = bounds("mission.off_course_lateral")
#: ... and from every place the robot looks for a course mark of their colour, at least this
#: factor farther (plus the margin) than that mark.
OFF_COURSE_FARTHER = 1.3
OFF_COURSE_MARGIN_MM = 500.0
ROBOT_RADIUS_MM = CREATE_RADIUS_MM


@dataclass(frozen=True)
class RandomMission:
    """A drawn mission and its world, and the documents they were built from."""

    seed: int
    mission: Mission
    world: World
    mission_doc: dict[str, Any]
    world_doc: dict[str, Any]
    range_kind: str  # "sim-fit" | "pinhole" | "fit×1.17" ...


def _route(rng: np.random.Generator) -> tuple[list[str], dict[str, Side]]:
    names = list(PALETTE)
    k = int(rng.integers(COLOURS_RANGE[0], COLOURS_RANGE[1] + 1))
    colours = [names[i] for i in sorted(rng.choice(len(names), size=k, replace=False))]
    sides: dict[str, Side] = {c: ("left" if rng.random() < 0.5 else "right") for c in colours}
    if len(set(sides.values())) == 1:  # mixed sides
        sides[colours[int(rng.integers(k))]] = "right" if sides[colours[0]] == "left" else "left"
    n = int(rng.integers(ROUTE_LENGTH_RANGE[0], ROUTE_LENGTH_RANGE[1] + 1))
    route: list[str] = []
    for _ in range(n):
        if route and rng.random() < REPEAT_PREVIOUS:
            route.append(route[-1])
        else:
            others = [c for c in colours if not route or c != route[-1]]
            route.append(others[int(rng.integers(len(others)))])
    for c in colours:  # every drawn colour is used
        if c not in route:
            route[int(rng.integers(n))] = c
    return route, sides


def _range_model(rng: np.random.Generator, radius_mm: float) -> tuple[dict[str, Any], str]:
    """The fit is of 100 mm marks: for marks of ``radius_mm`` (r ∝ R/d) its scale becomes
    a·(100/R)^b, as a fit of those marks would be."""
    kind = int(rng.integers(3))
    a, b = SIM_FIT[0] * (SIM_FIT_RADIUS_MM / radius_mm) ** SIM_FIT[1], SIM_FIT[1]
    if kind == 0:
        return {"model": "power", "a": round(a, 1), "b": b}, "sim-fit"
    if kind == 1:
        return {"model": "pinhole", "focal_px": FOCAL_PX}, "pinhole"
    scale = round(float(rng.uniform(*bounds("mission.range_scale"))), 3)
    return {"model": "power", "a": round(a * scale, 1), "b": b}, f"fit×{scale:g}"


def _off_course(rng: np.random.Generator, world: World, route: list[str],
                clearance_mm: float, radius_mm: float) -> list[MarkSpec]:
    marks = list(world.marks)
    start = world.robot.pose()
    fwd = (math.cos(start.theta), math.sin(start.theta))
    left = (-fwd[1], fwd[0])
    looks = [(start.x, start.y)] + [m.xy for m in marks[:-1]]  # where each waypoint is sought
    along_max = max((m.x_mm - start.x) * fwd[0] + (m.y_mm - start.y) * fwd[1] for m in marks)
    out: list[MarkSpec] = []
    for _ in range(int(rng.integers(OFF_COURSE_RANGE[0], OFF_COURSE_RANGE[1] + 1))):
        colour = route[int(rng.integers(len(route)))]
        for _try in range(60):
            a = float(rng.uniform(0.0, along_max + 1000.0))
            off = float(rng.uniform(*OFF_COURSE_LATERAL_MM)) * (1 if rng.random() < 0.5 else -1)
            xy = (start.x + a * fwd[0] + off * left[0], start.y + a * fwd[1] + off * left[1])
            ok = all(math.dist(xy, m.xy) > 2 * radius_mm + 400.0 for m in marks + out)
            for w, c in enumerate(route):
                if not ok:
                    break
                if c == colour:
                    d_course = math.dist(looks[w], marks[w].xy)
                    ok = math.dist(looks[w], xy) >= OFF_COURSE_FARTHER * d_course + \
                        OFF_COURSE_MARGIN_MM
            if ok:
                out.append(MarkSpec(colour=colour, x_mm=round(xy[0], 1),
                                             y_mm=round(xy[1], 1), radius_mm=radius_mm))
                break
    return out


def random_mission(seed: int) -> RandomMission:
    """The mission and world of ``seed`` (see the module docstring)."""
    if seed < 0:
        raise ValueError(f"seed must be ≥ 0, got {seed}")
    rng = np.random.default_rng([int(seed), 0x4D15])
    route, sides = _route(rng)
    radius = round(float(rng.uniform(*RADIUS_RANGE_MM)), 1)
    clearance = round(max(float(rng.uniform(*CLEARANCE_RANGE_MM)),
                          ROBOT_RADIUS_MM + radius + MIN_GAP_MM), 1)
    bypass = round(float(rng.uniform(*BYPASS_RANGE_MM)), 1)
    approach = round(float(rng.uniform(*APPROACH_SPEED_RANGE_MM_S)), 1)
    range_spec, range_kind = _range_model(rng, radius)
    colours = {c: {"hue": list(PALETTE[c][0]), "side": sides[c], "sat_min": PALETTE[c][1]}
               for c in dict.fromkeys(route)}
    mission_doc: dict[str, Any] = {
        "name": f"random-{seed}",
        "route": route,
        "marks": {"radius_mm": radius, "colours": colours},
        "robot": {"model": "create2", "max_speed_mm_s": 350},
        "camera": {"width": 640, "height": 480, "focal_px": FOCAL_PX, "range": range_spec},
        "navigation": {"bypass_distance_mm": bypass, "clearance_mm": clearance,
                       "approach_speed_mm_s": approach},
        "sim": {"world": "world.yaml", "seed": int(seed)},
    }
    text = yaml.safe_dump(mission_doc, sort_keys=False)
    mission = parse_mission(load_yaml_text(text, f"<random mission {seed}>"))
    base = generate_world(
        route, seed=seed, clearance_mm=clearance, radius_mm=radius, conditions="randomised",
        bypass_distance_mm=bypass, sides=[sides[c] for c in route],
        half_fov_deg=mission.camera.hfov_deg / 2.0)
    # The saturation floors a user would calibrate with these printed marks: the marks read
    # their paint's saturation (conditions.mark_saturation, ± its spread mark to mark) times
    # what full paint reads, so the floor scales with the palest mark (PALETTE's floors are
    # for full paint).
    cond = base.conditions
    palest = max(0.05, cond.mark_saturation - cond.mark_saturation_spread)
    if palest < 1.0:
        for c in colours:
            colours[c]["sat_min"] = round(PALETTE[c][1] * palest)
        text = yaml.safe_dump(mission_doc, sort_keys=False)
        mission = parse_mission(load_yaml_text(text, f"<random mission {seed}>"))
    extra = _off_course(rng, base, route, clearance, radius)
    world = World.model_validate(
        {**{k: getattr(base, k) for k in World.model_fields},
         "marks": base.marks + tuple(extra)})
    world_doc = world.model_dump(mode="json")
    return RandomMission(seed, mission, world, mission_doc, world_doc, range_kind)


def write_random_mission(seed: int, out_dir: str | Path) -> tuple[Path, Path]:
    """Write the mission and world of ``seed`` as ``OUT/mission.yaml`` and ``OUT/world.yaml``."""
    rm = random_mission(seed)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    header = (f"# Random mission of seed {seed} (marknav random-mission; range model "
              f"{rm.range_kind}). Replay: marknav run {out / 'mission.yaml'} --seed {seed}\n")
    mission_path, world_path = out / "mission.yaml", out / "world.yaml"
    mission_path.write_text(header + yaml.safe_dump(rm.mission_doc, sort_keys=False),
                            encoding="utf-8")
    world_path.write_text(f"# World of random mission {seed}; course = its first "
                          f"{len(rm.mission.route)} marks, in order\n"
                          + yaml.safe_dump(rm.world_doc, sort_keys=False), encoding="utf-8")
    return mission_path, world_path


