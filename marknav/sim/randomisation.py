"""The one table of randomised ranges: every (low, high) a randomised world, room, mission or
synthetic frame is drawn from, with its unit and physical reason.

A new realism effect, or a range that turns out wrong, is changed here and nowhere else. The
readers: the built-in engine's world generator (:mod:`marknav.sim.world.generators`), the
background clutter (:mod:`marknav.sim.world.clutter`), the built-in renderer's rooms
(:mod:`marknav.sim.scenery`), the lens (:mod:`marknav.sim.lens`), MuJoCo's rooms
(:mod:`marknav.sim.mujoco.scene`), random missions
(:mod:`marknav.runs.evaluation.random_mission`) and the synthetic frames of the detector's tests
and benchmark (:mod:`marknav.sim.synthetic.scene`, :mod:`marknav.sim.synthetic.composite`).

Names are ``area.quantity``. Where two engines or generators draw the same physical quantity from
different ranges, each has its own entry (``builtin.mark_yaw`` and ``mujoco.mark_yaw``), so that
what a seed gives stays what it was; where they share a range, they share the entry. Counts are
inclusive at both ends (``rng.integers(low, high + 1)``). The draws themselves (their order,
their random streams) stay with the generators: the table holds numbers, not code.

``docs/explanation/simulator-realism.md`` has the realism conditions' sources at length.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["RANGES", "Range", "bounds", "counts"]


@dataclass(frozen=True)
class Range:
    """A uniform draw between ``low`` and ``high`` (both included for counts), in ``unit``;
    ``reason`` says where the numbers come from."""

    low: float
    high: float
    unit: str
    reason: str

    @property
    def bounds(self) -> tuple[float, float]:
        """(low, high), as ``rng.uniform(*bounds)`` takes them."""
        return (self.low, self.high)

    @property
    def counts(self) -> tuple[int, int]:
        """(low, high) as integers, for counts and indices (both included)."""
        return (int(self.low), int(self.high))


def _r(low: float, high: float, unit: str, reason: str) -> Range:
    return Range(low, high, unit, reason)


#: name → range. Grouped by what draws it; the comments above a group say which module reads it.
RANGES: dict[str, Range] = {
    # --- image and wheel conditions (the built-in generator's main stream) -------------------
    "camera.lighting_gain": _r(0.5, 1.5, "× brightness",
                               "a dim evening room to a bright office or a sunlit window"),
    "camera.noise_sigma": _r(1.0, 6.0, "grey levels (σ)",
                             "webcam sensor noise, clean daylight to high gain in dim light"),
    "camera.blur_sigma": _r(0.0, 1.2, "px (Gaussian σ)",
                            "focus and cheap-lens softness of a fixed-focus webcam"),
    "camera.latency_frames": _r(0, 2, "frames",
                                "frames a USB webcam's buffer holds before the one delivered"),
    "wheels.mismatch": _r(-0.05, 0.05, "right/left − 1",
                          "unequal tyres and motors: the right wheel's ground speed off the "
                          "left's"),
    "wheels.slip": _r(0.0, 0.02, "fraction of travel", "tyres slipping on a smooth floor"),
    # --- realism conditions (their own stream; docs/explanation/simulator-realism.md) --------
    "camera.frame_rate": _r(15.0, 30.0, "Hz",
                            "UVC webcams deliver 30 fps, 15 fps when auto-exposure lengthens the "
                            "exposure in dim indoor light"),
    "camera.dropped_frames": _r(0.0, 0.05, "probability",
                                "frames that never arrive: a busy USB bus, MJPEG over Wi-Fi"),
    "camera.exposure": _r(5.0, 33.0, "ms",
                          "indoor auto-exposure runs 5 ms up to a whole frame period (33 ms at "
                          "30 fps)"),
    "camera.exposure_drift": _r(0.0, 0.15, "fraction of brightness",
                                "auto-exposure hunting as bright and dark parts come into view"),
    "camera.exposure_period": _r(3.0, 10.0, "s", "the period of that slow brightness swing"),
    "marks.saturation": _r(0.75, 1.0, "fraction of full",
                           "inkjet and laser primaries on paper, as a webcam sees them"),
    "marks.saturation_spread": _r(0.0, 0.08, "± fraction",
                                  "print runs and paper differ mark to mark"),
    "marks.hue_spread": _r(0.0, 3.0, "± OpenCV hue units",
                           "print runs and paper differ mark to mark"),
    "encoders.scale": _r(0.98, 1.02, "counts per nominal count",
                         "worn tyres, a wheel off the spec's 72 mm diameter"),
    "encoders.noise": _r(0.0, 1.0, "counts (σ per wheel and 15 ms tick)",
                         "quantisation (0.44 mm a count, Create 2) and gear backlash"),
    "wheels.accel": _r(400.0, 1000.0, "mm/s²",
                       "not in the OI spec: 0 → 300 mm/s in 0.3–0.75 s (an assumption)"),
    "link.command_delay": _r(1.0, 40.0, "ms",
                             "a USB-serial adapter 1–16 ms (FTDI latency timer), Bluetooth "
                             "serial up to ~40 ms"),
    "wheels.top_speed": _r(330.0, 500.0, "mm/s",
                           "battery sag: users report 330 mm/s for 500 commanded"),
    # --- the camera's lens (marknav.sim.lens.random_lens; its own stream) ----------------------
    "lens.k1": _r(-0.4, 0.0, "radial k1", "ordinary webcams' barrel distortion"),
    "lens.k2_excess": _r(0.0, 0.1, "radial k2 beyond 0.5·k1²",
                         "keeps the distortion monotonic, as real lenses are"),
    "lens.tangential": _r(-0.002, 0.002, "p1, p2", "a sensor not quite parallel to the lens"),
    "lens.principal_offset": _r(-0.04, 0.04, "fraction of the image's width / height",
                                "the principal point off the image centre (cheap mounting)"),
    # --- friction patches (their own stream; only with generate_world(patches=True)) --------
    "patches.count": _r(0, 2, "patches per world", "a rug or two, a polished or dusty patch"),
    "patches.radius": _r(300.0, 600.0, "mm", "a rug, a patch of polished or dusty floor"),
    "patches.slip": _r(0.02, 0.15, "fraction of travel", "a rug's pile to a dusty floor"),
    "patches.along_leg": _r(0.2, 0.8, "fraction of the leg",
                            "patches lie on the way, not under a mark or the start"),
    # --- generated courses (the built-in generator's main stream) ----------------------------
    "course.spacing": _r(1200.0, 2000.0, "mm",
                         "distance between consecutive marks: room for a bypass and a "
                         "re-acquisition in an ordinary room"),
    "course.first_mark": _r(1300.0, 2000.0, "mm",
                            "distance from the start to the first mark, in full view"),
    "course.lateral_offset": _r(100.0, 450.0, "mm",
                                "a mark's offset from the course's axis (signs alternate): a "
                                "slalom, not a straight line"),
    "builtin.mark_yaw": _r(-45.0, 45.0, "degrees from the line of sight",
                           "marks stood by hand, never edge-on (built-in engine)"),
    "mujoco.mark_yaw": _r(-60.0, 60.0, "degrees from the line of sight",
                          "MuJoCo renders the foreshortened ellipse itself, so it can go further"),
    # --- background clutter on the built-in renderer's far wall (clutter_items) -------------
    "clutter.long_side": _r(4.0, 14.0, "degrees", "posters and tape, 0.2–0.7 m at 3 m"),
    "clutter.aspect": _r(2.2, 5.0, "long/short side", "clearly not round: never a mark"),
    "clutter.stripes_aspect": _r(0.4, 0.9, "height/width", "a block of parallel tape stripes"),
    "clutter.stripe_bars": _r(3, 5, "bars", "a few parallel stripes"),
    "clutter.hue_jitter": _r(-6.0, 6.0, "OpenCV hue units",
                             "look-alikes near a common mark colour"),
    "clutter.saturation": _r(140, 255, "0..255", "printed posters and coloured tape"),
    "clutter.value": _r(110, 230, "0..255", "lit like the marks"),
    # --- the built-in renderer's rooms (marknav.sim.scenery) --------------------------------
    "room.floor_saturation": _r(60.0, 160.0, "0..255",
                                "wood and carpet floors; a mark's detector floor starts at 100"),
    "room.wall_tint_saturation": _r(60.0, 120.0, "0..255",
                                    "one colour dominating a room (a green room, an orange one)"),
    "room.pole_width": _r(2.0, 8.0, "px at f = 590 px", "table legs, cables, door frames"),
    "room.occluders": _r(0, 4, "poles", "table legs, lamp stands in front of the marks (both "
                         "engines)"),
    "room.distractors": _r(0, 5, "objects", "round things of near-mark colours off the course "
                           "(both engines)"),
    "room.near_hue_offset": _r(8.0, 10.0, "OpenCV hue units past a palette range",
                               "orange beside red, teal beside green, violet beside blue"),
    # --- MuJoCo's rooms (marknav.sim.mujoco.scene) ------------------------------------------
    "mujoco.light_count": _r(1, 3, "lamps", "a room's ceiling lamps"),
    "mujoco.light_height": _r(2200.0, 2800.0, "mm", "a room's ceiling"),
    "mujoco.light_diffuse": _r(0.25, 0.6, "fraction of MuJoCo's full scale",
                               "two overlapping lamps do not saturate a white wall"),
    "mujoco.light_tint": _r(-0.25, 0.25, "per channel, about white",
                            "incandescent amber to overcast blue"),
    "mujoco.dim_factor": _r(0.3, 0.5, "× every light",
                            "an evening room lit by one lamp is 3–10× darker than an office; "
                            "auto-exposure recovers part of it"),
    "mujoco.ambient": _r(0.1, 0.35, "fraction of full scale", "light scattered by the walls"),
    "mujoco.checker": _r(150.0, 400.0, "mm", "floor tiles or a rug's squares"),
    "mujoco.occluder_radius": _r(10.0, 30.0, "mm", "table legs, lamp stands"),
    "mujoco.occluder_height": _r(500.0, 2000.0, "mm", "table legs to lamp stands"),
    "mujoco.occluder_grey": _r(0.15, 0.8, "0..1", "dark metal to pale wood"),
    "mujoco.distractor_size": _r(80.0, 250.0, "mm", "balls and boxes lying about a room"),
    "mujoco.corridor_offset": _r(0.0, 1500.0, "mm beyond the lane's margin",
                                 "where they cross the view when the camera turns to search or "
                                 "bypass"),
    # --- random missions (marknav.runs.evaluation.random_mission) ---------------------------
    "mission.colours": _r(2, 5, "colours", "a course of a few mark colours"),
    "mission.route_length": _r(3, 12, "waypoints", "short to long courses"),
    "mission.mark_radius": _r(60.0, 100.0, "mm", "A4 to A3 printed discs"),
    "mission.clearance": _r(250.0, 450.0, "mm", "a tight to a generous bypass"),
    "mission.bypass_distance": _r(700.0, 1200.0, "mm", "where a bypass begins"),
    "mission.approach_speed": _r(150.0, 300.0, "mm/s", "the Create's useful speeds"),
    "mission.range_scale": _r(0.75, 1.25, "× the range law's scale",
                              "a range law that over- or under-estimates every distance"),
    "mission.off_course_marks": _r(0, 3, "marks", "marks of other courses in the room"),
    "mission.off_course_lateral": _r(1400.0, 2200.0, "mm beside the axis",
                                     "in view, never nearer than the course's own mark"),
    # --- synthetic scenes (marknav.sim.synthetic.scene: SceneSpec defaults, BENCH_SPEC) -----
    "synthetic.mark_radius": _r(12.0, 60.0, "px", "marks from ~5 m down to ~1 m at f = 590 px"),
    "synthetic.axis_ratio": _r(0.5, 0.95, "minor/major", "marks turned 18–60° from the camera"),
    "synthetic.occlusion": _r(0.1, 0.3, "share of the outline", "a board hiding part of a mark"),
    "synthetic.mark_value": _r(130.0, 160.0, "0..255", "paint in ordinary room light"),
    "synthetic.background": _r(90.0, 150.0, "0..255", "a grey floor, dim to bright"),
    "synthetic.noise_sigma": _r(2.0, 2.0, "grey levels (σ)", "a webcam in good light"),
    "bench.mark_radius": _r(15.0, 70.0, "px", "the benchmark's marks, ~4 m down to ~0.8 m"),
    "bench.gain": _r(0.6, 1.4, "× brightness", "dim to bright rooms"),
    "bench.blur_sigma": _r(0.0, 1.2, "px (Gaussian σ)", "as camera.blur_sigma"),
    "bench.noise_sigma": _r(1.0, 3.0, "grey levels (σ)", "good to middling light"),
    # --- composited frames (marknav.sim.synthetic.composite: CompositeSpec defaults) --------
    "composite.mark_radius": _r(10.0, 60.0, "px", "marks from ~6 m down to ~1 m at f = 590 px"),
    "composite.mark_yaw": _r(0.0, 55.0, "degrees", "marks turned from the camera"),
    "composite.occluder_width": _r(2.0, 8.0, "px", "poles, wires and seams"),
    "composite.floor_saturation": _r(90.0, 160.0, "0..255",
                                     "saturated wood and carpet behind a mark"),
    "composite.overlap": _r(0.1, 0.3, "share of the outline", "an object hiding part of a mark"),
    "composite.blur_sigma": _r(0.0, 1.0, "px (Gaussian σ)", "webcam softness"),
    "composite.noise_sigma": _r(1.0, 3.0, "grey levels (σ)", "good to middling light"),
    "composite.gain": _r(0.75, 1.25, "× brightness", "a room's light about the photograph's"),
    "composite.mark_value": _r(150.0, 230.0, "0..255", "paint as bright as the photographs"),
}


def bounds(name: str) -> tuple[float, float]:
    """The (low, high) of the range ``name``."""
    return RANGES[name].bounds


def counts(name: str) -> tuple[int, int]:
    """The (low, high) of the count range ``name``, both included."""
    return RANGES[name].counts
