"""Held-out figures and an ablation table for the detector: does every stage earn its place?

**Split before tuning.** Every frame belongs to a corpus and has a name; :func:`half` puts it in
the *tuning* half or the *held-out* half by the first byte of the SHA-256 of ``corpus/name``
(even: tuning), so the split is fixed, needs no list, and a frame added later falls where its name
puts it. Composited frames are named by their background photograph, so a photograph and the
marks painted into it are never on both sides. Thresholds may be tuned on the tuning half only;
the figures that judge them are the held-out half's.

**Corpora** (all with their truth):

- ``real``: the labelled photographs of ``tests/data`` (``labels.json``): recall of the labelled
  marks with the label palette, and false marks on the natural photographs with the
  red/green/blue palette (labelled and ignored objects are not false marks);
- ``composite``: marks painted into those photographs (:mod:`marknav.sim.synthetic.composite`);
- ``synthetic``: the benchmark's synthetic scenes with tilted, occluded and cast-lit marks
  (:func:`marknav.sim.synthetic.scene.render_scene`);
- ``simulator``: frames of the simulator's renderer in dim, normal and bright light, with warm,
  cool and no casts, each mark's truth the ellipse fitted to its projected rim;
- ``mujoco`` (only with the ``mujoco`` extra and headless OpenGL; ``mujoco=0`` leaves it out):
  frames MuJoCo renders of the randomised rooms ``evaluate --engine mujoco`` drives through
  (lamps with shadows and tints, dim rooms, textures, poles, near-colour distractors, marks
  turned up to 60°), from poses along the course; the truth is the same projected rim (one
  pinhole model for both renderers), marks behind a nearer mark are ignored, and frames are
  tagged ``dim`` (median grey under 60 of 255) and ``turned`` (a mark seen at an axis ratio
  under 0.6).

**Scoring** (the issue's): a mark at least 80 % visible (whole in the image, not overlapped by a
nearer mark, less than a fifth of its outline occluded) is found when a detection of the right
colour has its centre within 0.2 r and its radius within 15 %; false marks are detections that
match no mark (nor an ignored object); the range error is |h_true / h_found − 1|, h the vertical
semi-axis (range ∝ 1/h, :func:`marknav.vision.estimate.estimate_disc`).

**Ablation**: the detector with one stage or veto switched off at a time (:data:`ABLATIONS`:
a stage replaced by a plain one, or the config that switches a part off), and the least OpenCV
detector (:func:`marknav.vision.detect.least.least_opencv_detector`) as the floor; per variant
recall, false marks per frame, range error p95 and cost (ms, p50) on the held-out half.
"""

from __future__ import annotations

import hashlib
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import cv2
import numpy as np

from marknav.sim.synthetic.scene import Image, SceneSpec, render_scene
from marknav.vision.detect import DetectorConfig, Mark
from marknav.vision.detect.pipeline import STAGES, Stage, run_stages
from marknav.vision.detect.scene import SEARCH_SCALE, Scene
from marknav.vision.estimate import upright_extents
from marknav.vision.palette import DEFAULT_PALETTE, Palette

__all__ = ["ABLATIONS", "Frame", "Truth", "ablated", "half", "holdout_report", "load_corpora",
           "score"]

Half = Literal["tuning", "held_out"]

def _plain_photometry(scene: Scene, config: DetectorConfig) -> Scene:
    """Photometry switched off: the search image at half size, no gain, no light correction."""
    from dataclasses import replace as replaced

    from marknav.vision.detect.photometry import table_of

    h, w = scene.image.shape[:2]
    small = cv2.resize(scene.image, (max(1, w // SEARCH_SCALE), max(1, h // SEARCH_SCALE)),
                       interpolation=cv2.INTER_AREA)
    gains = np.ones(3)
    return replaced(scene, gains=gains, lut=table_of(gains), small=small,
                    hsv=cv2.cvtColor(small, cv2.COLOR_BGR2HSV))


def _no_suppression(scene: Scene, config: DetectorConfig) -> Scene:
    """Suppression switched off: every measured mark, largest first."""
    from dataclasses import replace as replaced

    return replaced(scene, marks=tuple(sorted(scene.marks, key=lambda m: -m.radius)))


#: What can be switched off: a stage replaced (name, plain stage) or config changes per stage.
ABLATIONS: dict[str, tuple[str, Stage] | dict[str, dict[str, Any]]] = {
    "photometry (gain and light colour)": ("photometry", _plain_photometry),
    "exposure gain": {"photometry": {"max_gain": 1.0}},
    "pale-paint floors (sat_share 1)": {"classify": {"sat_share": 1.0}},
    "cut along colour edges": {"segment": {"edge_step": 0.0}},
    "joining across thin occluders": {"segment": {"bridge_px": 0}},
    "outline test": {"shape": {"max_outline_share": 1e9}},
    "contrast veto": {"shape": {"min_contrast": 0.0}},
    "texture veto": {"shape": {"max_texture": 1e9}},
    "suppression": ("suppress", _no_suppression),
}


def ablated(palette: Palette, change: tuple[str, Stage] | dict[str, dict[str, Any]] | None = None,
            ) -> Callable[[Image], list[Mark]]:
    """The detector of ``palette`` with one :data:`ABLATIONS` entry applied (``None``: none)."""
    config = DetectorConfig()
    stages = STAGES
    if isinstance(change, tuple):
        stages = tuple(change if name == change[0] else (name, st) for name, st in STAGES)
    elif change:
        config = config.with_(**change)
    return lambda image: list(run_stages(image, palette, config, stages=stages).marks)


def half(corpus: str, name: str) -> Half:
    """The half ``corpus/name`` belongs to: tuning when the first byte of its SHA-256 is even."""
    digest = hashlib.sha256(f"{corpus}/{name}".encode()).digest()
    return "tuning" if digest[0] % 2 == 0 else "held_out"


@dataclass(frozen=True)
class Truth:
    """A mark to be found (px): centre, semi-axes (a ≥ b), angle of a (deg)."""

    colour: str
    x: float
    y: float
    a: float
    b: float
    angle_deg: float

    @property
    def upright(self) -> float:
        return upright_extents((self.a, self.b), self.angle_deg)[1]


@dataclass(frozen=True)
class Frame:
    corpus: str
    name: str
    image: Image
    palette: Palette
    #: Marks at least 80 % visible: each must be found.
    marks: tuple[Truth, ...]
    #: Objects a detector may or may not report (partly visible marks, round things labelled
    #: ignorable): not counted either way.
    ignore: tuple[Truth, ...] = ()
    #: Whether detections other than ``marks``/``ignore`` count as false marks.
    counts_false: bool = True
    #: Conditions (``dim``, ``tinted``, ...), for recall by condition.
    tags: tuple[str, ...] = ()


def _hit(t: Truth, m: Mark | tuple[str, float, float, float, float]) -> bool:
    colour, x, y, radius = (m.colour, m.x, m.y, m.radius) if isinstance(m, Mark) else m[:4]
    return colour == t.colour and math.hypot(x - t.x, y - t.y) <= 0.2 * t.a and \
        abs(radius - t.a) <= 0.15 * t.a


def _near(t: Truth, m: Mark | tuple[str, float, float, float, float]) -> bool:
    x, y = (m.x, m.y) if isinstance(m, Mark) else m[1:3]
    return math.hypot(x - t.x, y - t.y) <= max(t.a, 3.0)


# ------------------------------------------------------------------------------- corpora


def _real(root: Path) -> list[Frame]:
    from marknav.runs.metrics.photo_corpus import load_corpus

    photos, palette, negative = load_corpus(root)
    out = []
    for p in photos:
        marks = tuple(Truth(m.colour, m.x, m.y, m.radius, m.radius, 0.0) for m in p.marks)
        ignore = tuple(Truth(m.colour, m.x, m.y, m.radius, m.radius, 0.0) for m in p.ignore)
        if marks:
            out.append(Frame("real", p.name, p.image, palette, marks, ignore,
                             counts_false=False, tags=("labelled",)))
        if p.natural:
            out.append(Frame("real", p.name, p.image, negative, (), marks + ignore,
                             tags=("natural",)))
    return out


def _composite(root: Path, per_condition: int) -> list[Frame]:
    from marknav.sim.synthetic.composite import COMPOSITE_PALETTE, composite_frames, load_photos

    out = []
    for k, f in enumerate(composite_frames(load_photos(root / "real"),
                                           per_condition=per_condition)):
        marks: list[Truth] = []
        ignore: list[Truth] = []
        for t in f.marks:
            truth = Truth(t.colour, t.x, t.y, t.a, t.b, t.angle_deg)
            (ignore if t.cut or t.occluded > 0.2 else marks).append(truth)
        out.append(Frame("composite", f"{f.photo}#{k}", f.image, COMPOSITE_PALETTE,
                         tuple(marks), tuple(ignore), tags=f.conditions))
    return out


def _synthetic(n: int) -> list[Frame]:
    spec = SceneSpec(n_marks=3, radius=(8.0, 60.0), ellipse_share=0.4, axis_ratio=(0.5, 0.95),
                     n_clutter=8, occluded_share=0.3, occlusion=(0.05, 0.3), cut_share=0.1,
                     touching_pairs=0, gain=(0.45, 1.4), cast=0.2, blur_sigma=(0.0, 1.2),
                     noise_sigma=(1.0, 4.0))
    rng = np.random.default_rng([7, 0x5CE4E])
    out = []
    for k in range(n):
        scene = render_scene(rng, spec, DEFAULT_PALETTE)
        marks: list[Truth] = []
        ignore: list[Truth] = []
        for t in scene.marks:
            truth = Truth(t.colour, t.x, t.y, t.a, t.b, t.angle_deg)
            (ignore if t.cut or t.occluded > 0.2 else marks).append(truth)
        out.append(Frame("synthetic", f"scene-{k}", scene.image, DEFAULT_PALETTE,
                         tuple(marks), tuple(ignore)))
    return out


def _simulator(n: int) -> list[Frame]:
    from marknav.planning.kinematics import Pose
    from marknav.sim.builtin_camera import CameraConfig, project_marks, render
    from marknav.sim.world.generate import generate_world
    from marknav.sim.world.schema import Conditions

    config = CameraConfig()
    rng = np.random.default_rng([11, 0x514])
    lights = (("dim", 0.5), ("normal", 1.0), ("bright", 1.4))
    casts: tuple[Literal["none", "warm", "cool"], ...] = ("none", "warm", "cool")
    floors: tuple[Literal["plain", "wood", "carpet"], ...] = ("plain", "wood", "carpet")
    out: list[Frame] = []
    k = 0
    while len(out) < n:
        light, gain = lights[k % 3]
        cast = casts[(k // 3) % 3]
        cond = Conditions(lighting_gain=gain, cast=cast, floor=floors[k % 3],
                          blur_sigma_px=float(rng.uniform(0.0, 1.0)))
        world = generate_world(["red", "green", "blue", "red"], seed=1000 + k,
                               clearance_mm=300.0, conditions=cond)
        k += 1
        pose = Pose(float(rng.uniform(-200, 200)), float(rng.uniform(0, 1500)),
                    math.pi / 2 + float(rng.uniform(-0.35, 0.35)))
        image = np.asarray(render(world, pose, config, DEFAULT_PALETTE, rng), np.uint8)
        projected = sorted(project_marks(world, pose, config), key=lambda p: p.depth_mm)
        marks: list[Truth] = []
        ignore: list[Truth] = []
        for i, p in enumerate(projected):
            if len(p.polygon) < 5:
                continue
            (x, y), (w, h), ang = cv2.fitEllipse(p.polygon.astype(np.float32))
            a, b = 0.5 * max(w, h), 0.5 * min(w, h)
            truth = Truth(world.marks[p.index].colour, x, y, a, b,
                          (ang + (90.0 if w < h else 0.0)) % 180.0)
            if a < 5.0:
                continue  # below the detector's smallest radius
            hidden = any(_overlap(p.bbox, q.bbox) for q in projected[:i])
            (marks if p.inside(config) and not hidden else ignore).append(truth)
        tags = (light,) + (("tinted",) if cast != "none" else ())
        out.append(Frame("simulator", f"world-{k}", image, DEFAULT_PALETTE, tuple(marks),
                         tuple(ignore), tags=tags))
    return out


def _mujoco(n: int) -> list[Frame]:
    """``n`` MuJoCo frames of randomised rooms (see the module docstring); none without MuJoCo."""
    from marknav.planning.kinematics import Pose
    from marknav.sim.builtin_camera import CameraConfig, project_marks
    from marknav.sim.lens import Lens
    from marknav.sim.world.generate import generate_world

    if n <= 0:
        return []
    try:
        from marknav.sim.mujoco.gl import import_mujoco

        import_mujoco()
    except Exception:  # no extra or no OpenGL: the corpus is left out, not the report
        return []
    from marknav.core.clock import ManualClock
    from marknav.sim.mujoco.body import MujocoBody
    from marknav.sim.mujoco.camera import MujocoCamera

    config = CameraConfig()
    rng = np.random.default_rng([13, 0x3D5C])
    out: list[Frame] = []
    k = 0
    while len(out) < n:
        world = generate_world(["red", "green", "blue", "red"], seed=2000 + k,
                               clearance_mm=300.0, conditions="randomised", engine="mujoco")
        world = world.with_conditions(world.conditions.model_copy(update={"lens": Lens()}))
        k += 1
        body = MujocoBody(world, tuple(DEFAULT_PALETTE), camera=config, shadows=True)
        with MujocoCamera(body, clock=ManualClock(), seed=k) as camera:
            for _ in range(3):  # three views per room: its set-up costs more than a frame
                mark = world.marks[int(rng.integers(0, len(world.marks)))]
                back = float(rng.uniform(700.0, 2500.0))
                x = mark.x_mm + float(rng.uniform(-500.0, 500.0))
                y = mark.y_mm - back
                look = math.atan2(mark.y_mm - y, mark.x_mm - x) + float(rng.uniform(-0.3, 0.3))
                pose = Pose(x, y, look)
                body.set_pose(pose)
                image = camera.render()
                projected = sorted(project_marks(world, pose, config), key=lambda p: p.depth_mm)
                marks: list[Truth] = []
                ignore: list[Truth] = []
                turned = False
                for i, p in enumerate(projected):
                    if len(p.polygon) < 5:
                        continue
                    (u, v), (w, h), ang = cv2.fitEllipse(p.polygon.astype(np.float32))
                    a, b = 0.5 * max(w, h), 0.5 * min(w, h)
                    if a < 5.0:
                        continue
                    truth = Truth(world.marks[p.index].colour, u, v, a, b,
                                  (ang + (90.0 if w < h else 0.0)) % 180.0)
                    hidden = any(_overlap(p.bbox, q.bbox) for q in projected[:i])
                    seen = p.inside(config) and not hidden
                    (marks if seen else ignore).append(truth)
                    turned = turned or (seen and b < 0.6 * a)
                grey = float(np.median(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)))
                tags = (("dim",) if grey < 60.0 else ()) + (("turned",) if turned else ())
                out.append(Frame("mujoco", f"room-{k}-{len(out)}", image, DEFAULT_PALETTE,
                                 tuple(marks), tuple(ignore), tags=tags))
    return out[:n]


def _overlap(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def load_corpora(root: str | Path, *, composites_per_condition: int = 4, synthetic: int = 40,
                 simulator: int = 36, mujoco: int = 60) -> list[Frame]:
    """Every corpus's frames (``root``: the source tree's ``tests/data``)."""
    root = Path(root)
    return (_real(root) + _composite(root, composites_per_condition) + _synthetic(synthetic)
            + _simulator(simulator) + _mujoco(mujoco))


# ------------------------------------------------------------------------------- scoring

Detect = Callable[[Image], Sequence[Mark | tuple[str, float, float, float, float]]]


def score(frames: Sequence[Frame], make: Callable[[Palette], Detect]) -> dict[str, Any]:
    """Recall, false marks per frame, range error p95 and cost (ms p50) of the detector
    ``make(palette)`` on ``frames``, with recall per corpus and per tag."""
    detectors: dict[Palette, Detect] = {}
    found = total = false = counted = 0
    errors: list[float] = []
    times: list[float] = []
    by: dict[str, list[int]] = {}
    for f in frames:
        detect = detectors.get(f.palette)
        if detect is None:
            detect = detectors[f.palette] = make(f.palette)
            detect(f.image)  # set-up outside the timing
        t0 = time.perf_counter()
        marks = list(detect(f.image))
        times.append((time.perf_counter() - t0) * 1e3)
        used: set[int] = set()
        for t in f.marks:
            hit = next((j for j, m in enumerate(marks) if j not in used and _hit(t, m)), None)
            for key in (f.corpus, *f.tags):
                row = by.setdefault(key, [0, 0])
                row[1] += 1
                row[0] += hit is not None
            total += 1
            if hit is not None:
                found += 1
                used.add(hit)
                m = marks[hit]
                h = upright_extents(m.axes, m.angle_deg)[1] if isinstance(m, Mark) else m[4]
                errors.append(abs(t.upright / h - 1.0))
        if f.counts_false:
            counted += 1
            false += sum(1 for j, m in enumerate(marks) if j not in used and not any(
                _near(t, m) for t in f.marks + f.ignore))
    return {"frames": len(frames), "marks": total,
            "recall": round(found / total, 4) if total else None,
            "false_per_frame": round(false / counted, 3) if counted else None,
            "range_err_p95": round(float(np.percentile(errors, 95)), 4) if errors else None,
            "ms_p50": round(float(np.median(times)), 3) if times else None,
            "recall_by": {k: round(r[0] / r[1], 3) for k, r in sorted(by.items()) if r[1]}}


def holdout_report(root: str | Path, *, ablate: bool = True, **sizes: int) -> dict[str, Any]:
    """The detector on both halves of every corpus, and (``ablate``) the ablation table on the
    held-out half (see the module docstring)."""
    from marknav.vision.detect.least import least_opencv_detector

    previous = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        frames = load_corpora(root, **sizes)
        halves = {h: [f for f in frames if half(f.corpus, f.name) == h]
                  for h in ("tuning", "held_out")}

        def detector(change: tuple[str, Stage] | dict[str, dict[str, Any]] | None = None,
                     ) -> Callable[[Palette], Detect]:
            return lambda palette: ablated(palette, change)

        out: dict[str, Any] = {"split": "sha256(corpus/name)[0] even: tuning; odd: held out",
                               "detector": {h: score(fs, detector()) for h, fs in halves.items()}}
        if ablate:
            held = halves["held_out"]
            table: dict[str, Any] = {"all stages": out["detector"]["held_out"]}
            for stage, change in ABLATIONS.items():
                table[f"without {stage}"] = score(held, detector(change))
            table["least OpenCV detector"] = score(held, least_opencv_detector)
            out["ablation_held_out"] = table
    finally:
        cv2.setNumThreads(previous)
    return out
