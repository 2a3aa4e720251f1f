"""The simulated world: marks, robot start, walls, conditions; course checks, contacts and
generated worlds. One module per idea:

- :mod:`.schema`: the world file's models (:class:`World`, :class:`Conditions`, ...) and
  :func:`load_world`;
- :mod:`.json_schema`: the JSON Schema of world files (``marknav schema --world``);
- :mod:`.course`: does a world fit a mission (:func:`check_course`,
  :func:`check_against_palette`);
- :mod:`.contacts`: the robot's disc against marks, walls and boxes, the bumper bits;
- :mod:`.clutter`: the background's posters and stripes;
- :mod:`.generate`: :func:`generate_world`, running the generators of :mod:`.generators` (one
  file each: conditions, room, lens, realism, course, MuJoCo room, patches), whose ranges are the
  one table of :mod:`marknav.sim.randomisation`.

The package re-exports the names used widely, so ``from marknav.sim.world import World`` works;
code inside marknav imports from the defining module. **Run-report measures from ground truth**
live in :mod:`marknav.runs.metrics` (passes, truth).
"""

from __future__ import annotations

from marknav.sim.randomisation import bounds as _bounds
from marknav.sim.world.clutter import ClutterItem, clutter_items
from marknav.sim.world.contacts import (
    BOTH_BUMPS_HALF_ANGLE_DEG,
    BUMPER_HALF_ARC_DEG,
    Bumps,
    Contact,
    bumper_sides,
    bumps,
    contacts,
    push_out,
)
from marknav.sim.world.course import check_against_palette, check_course
from marknav.sim.world.generate import generate_world
from marknav.sim.world.generators.conditions import RANDOM_CASTS, random_conditions
from marknav.sim.world.generators.course import (
    DEFAULT_HALF_FOV_DEG,
    FIRST_MARK_FOV_MARGIN_DEG,
    GENERATION_TRIES,
    MAX_SEARCH_TURN_DEG,
    REACQUIRE_MARGIN_MM,
)
from marknav.sim.world.generators.patches import random_patches
from marknav.sim.world.generators.realism import random_realism
from marknav.sim.world.schema import (
    CAST_GAINS_BGR,
    CREATE_RADIUS_MM,
    DEFAULT_MARK_RADIUS_MM,
    Background,
    Box,
    Conditions,
    FaultEvent,
    FrictionPatch,
    MarkSpec,
    RobotStart,
    Wall,
    World,
    load_world,
)

# Former names of entries of the table in marknav.sim.randomisation, kept for existing callers.
LIGHTING_GAIN_RANGE = _bounds("camera.lighting_gain")
NOISE_SIGMA_RANGE = _bounds("camera.noise_sigma")
BLUR_SIGMA_RANGE_PX = _bounds("camera.blur_sigma")
WHEEL_SLIP_MAX = _bounds("wheels.slip")[1]
SPACING_RANGE_MM = _bounds("course.spacing")
FIRST_MARK_RANGE_MM = _bounds("course.first_mark")
LATERAL_OFFSET_RANGE_MM = _bounds("course.lateral_offset")

__all__ = [
    "BLUR_SIGMA_RANGE_PX",
    "BOTH_BUMPS_HALF_ANGLE_DEG",
    "BUMPER_HALF_ARC_DEG",
    "CAST_GAINS_BGR",
    "CREATE_RADIUS_MM",
    "DEFAULT_HALF_FOV_DEG",
    "DEFAULT_MARK_RADIUS_MM",
    "FIRST_MARK_FOV_MARGIN_DEG",
    "FIRST_MARK_RANGE_MM",
    "GENERATION_TRIES",
    "LATERAL_OFFSET_RANGE_MM",
    "LIGHTING_GAIN_RANGE",
    "MAX_SEARCH_TURN_DEG",
    "NOISE_SIGMA_RANGE",
    "RANDOM_CASTS",
    "REACQUIRE_MARGIN_MM",
    "SPACING_RANGE_MM",
    "WHEEL_SLIP_MAX",
    "Background",
    "Box",
    "Bumps",
    "ClutterItem",
    "Conditions",
    "Contact",
    "FaultEvent",
    "FrictionPatch",
    "MarkSpec",
    "RobotStart",
    "Wall",
    "World",
    "bumper_sides",
    "bumps",
    "check_against_palette",
    "check_course",
    "clutter_items",
    "contacts",
    "generate_world",
    "load_world",
    "push_out",
    "random_conditions",
    "random_patches",
    "random_realism",
]
