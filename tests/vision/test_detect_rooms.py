"""Detector behaviour on what real rooms and photographs add (issue #10): glows
are not marks, readings of one mark do not suppress it, a coloured surface's clipped highlights
are not the light's white."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from marknav.vision.detect import Detector, DetectorConfig, Mark
from marknav.vision.detect.glow import GLOW_RATIO, glow_ratio, is_glow
from marknav.vision.detect.suppress import _suppress_duplicates
from marknav.vision.palette import ColourRange

RED = ColourRange("red", 170, 8)
GREEN = ColourRange("green", 40, 85)
BLUE = ColourRange("blue", 95, 130)
PALETTE = (RED, GREEN, BLUE)


def _scene(h: int = 240, w: int = 320, back: tuple[int, int, int] = (20, 20, 20),
           ) -> np.ndarray:
    img = np.empty((h, w, 3), np.float32)
    img[:] = back
    return img


def _disc(img: np.ndarray, x: float, y: float, r: float, bgr: tuple[float, float, float],
          profile: str) -> None:
    """A red-ish disc: ``flat`` with a linear shading gradient (0.65..1.1 across it, as the
    composited frames paint marks), or a ``glow`` falling off from a bright core."""
    h, w = img.shape[:2]
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    d = np.hypot(xx - x, yy - y) / r
    # 4x4 supersampled coverage of the disc's edge.
    cover = np.clip((1.0 - d) * r + 0.5, 0.0, 1.0)
    if profile == "flat":
        light = 0.875 + 0.225 * (xx - x) / r
    else:
        light = np.clip(1.25 - 0.9 * d, 0.3, 1.25)
    colour = np.array(bgr, np.float32)[None, None, :] * light[..., None]
    img[:] = img * (1.0 - cover[..., None]) + colour * cover[..., None]


def _finish(img: np.ndarray, seed: int = 0) -> np.ndarray:
    noisy = img + np.random.default_rng(seed).normal(0.0, 2.0, img.shape).astype(np.float32)
    out: np.ndarray = np.clip(np.rint(noisy), 0, 255).astype(np.uint8)
    return out


@pytest.mark.parametrize("radius", [6.0, 12.0, 30.0])
def test_a_flat_mark_is_reported_and_a_glow_of_its_size_and_colour_is_not(radius: float,
                                                                          ) -> None:
    img = _scene()
    _disc(img, 90.0, 120.0, radius, (20.0, 20.0, 190.0), "flat")
    _disc(img, 230.0, 120.0, radius, (20.0, 20.0, 190.0), "glow")
    image = _finish(img)
    marks = Detector(PALETTE).detect(image)
    assert [round(m.x) for m in marks] == [90], marks
    assert marks[0].radius == pytest.approx(radius, rel=0.1)
    # Without the test both are read as red marks: it is the glow test that drops one.
    both = Detector(PALETTE, DetectorConfig(reject_glows=False)).detect(image)
    assert sorted(round(m.x) for m in both) == [90, 230], both


def test_glow_ratio_measures_core_over_ring() -> None:
    img = _scene()
    _disc(img, 90.0, 120.0, 20.0, (20.0, 20.0, 190.0), "flat")
    _disc(img, 230.0, 120.0, 20.0, (20.0, 20.0, 190.0), "glow")
    image = _finish(img)

    def at(x: float) -> Mark:
        return Mark("red", x, 120.0, 20.0, (20.0, 20.0), 0.0, "circle", 1.0)
    flat, glow = glow_ratio(image, at(90.0)), glow_ratio(image, at(230.0))
    assert flat is not None and glow is not None
    assert flat == pytest.approx(1.0, abs=0.05)
    assert glow > GLOW_RATIO
    assert not is_glow(image, at(90.0)) and is_glow(image, at(230.0))
    # A mark wholly outside the frame has no pixels to measure.
    assert glow_ratio(image, at(-200.0)) is None


def _mark(x: float, r: float, score: float) -> Mark:
    return Mark("red", x, 100.0, r, (r, r), 0.0, "circle", score)


def test_a_mark_holding_two_readings_of_one_piece_stands() -> None:
    """A pole across a mark: its joined whole (r 31.5) and one half read twice (r 22.8, a
    worse score) — the whole is the mark, not an outline fitted across two marks."""
    whole, half = _mark(524.4, 31.5, 0.66), _mark(532.3, 22.8, 0.33)
    kept = _suppress_duplicates([half, whole, _mark(532.3, 22.8, 0.33)])
    assert kept == [whole]


def test_an_outline_across_two_touching_marks_still_goes() -> None:
    left, right = _mark(100.0, 20.0, 0.6), _mark(140.0, 20.0, 0.6)
    across = _mark(120.0, 40.0, 0.9)  # better scored, but it holds both centres
    kept = _suppress_duplicates([across, left, right])
    assert sorted(m.x for m in kept) == [100.0, 140.0]


def test_clipped_highlights_of_an_orange_surface_are_not_white() -> None:
    """Composite frame 9 (a crop of retina.jpg): an orange surface whose bright part is
    clipped in red only. Those pixels once counted as the near-whites of an overexposed frame,
    the gains (1.58, 1.19, 0.65) made a grey pole blue, and it merged with the blue mark it
    crossed. A grey pole and a blue mark on such a surface: gains stay 1, the mark is found
    whole."""
    h, w = 240, 320
    img = np.empty((h, w, 3), np.float32)
    xx = np.arange(w, dtype=np.float32)[None, :]
    # Orange, S ≈ 150-190 (too saturated for a cast), brighter to the right until red clips.
    img[..., 0] = 40.0 + 60.0 * xx / w
    img[..., 1] = 80.0 + 60.0 * xx / w
    img[..., 2] = 200.0 + 120.0 * xx / w
    _disc(img, 100.0, 120.0, 20.0, (190.0, 40.0, 10.0), "flat")
    cv2.rectangle(img, (99, 80), (100, 160), (128.0, 128.0, 128.0), cv2.FILLED)  # a 2 px pole
    image = _finish(img)
    detector = Detector(PALETTE)
    marks = detector.detect(image)
    assert all(abs(g - 1.0) <= 0.02 for g in detector.last_gains), detector.last_gains
    blue = [m for m in marks if m.colour == "blue"]
    assert len(blue) == 1, marks
    assert math.hypot(blue[0].x - 100.0, blue[0].y - 120.0) < 1.5
    assert blue[0].radius == pytest.approx(20.0, rel=0.1)


def _photo_at_640(name: str) -> np.ndarray:
    """``tests/data/real/NAME`` resized to 640 px on its long side (as the corpus's false-mark
    figure reads it)."""
    path = Path(__file__).resolve().parents[1] / "data" / "real" / name
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    assert image is not None
    s = 640 / max(image.shape[:2])
    out: np.ndarray = cv2.resize(image, (round(image.shape[1] * s), round(image.shape[0] * s)),
                                 interpolation=cv2.INTER_AREA)
    return out


def test_no_galaxy_of_the_hubble_deep_field_is_a_mark() -> None:
    """``tests/data/real/hubble_deep_field.jpg`` at 640 px with a red/green/blue palette: seven
    small red galaxies came out as marks (half the corpus's false marks). Their cores glow."""
    small = _photo_at_640("hubble_deep_field.jpg")
    assert Detector(PALETTE).detect(small) == []
    glows = Detector(PALETTE, DetectorConfig(reject_glows=False)).detect(small)
    assert len(glows) >= 5 and all(is_glow(small, m) for m in glows), glows


def _composite_crop(name: str) -> np.ndarray:
    """A crop of a composited frame of ``marknav bench vision`` (``tests/data/composite-frames``,
    truth in its README)."""
    path = Path(__file__).resolve().parents[1] / "data" / "composite-frames" / name
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    assert image is not None
    return image


def _only(marks: list[Mark], colour: str) -> Mark:
    (mark,) = [m for m in marks if m.colour == colour]
    return mark


def test_a_large_shaded_mark_beside_a_board_passes_the_search_image_outline_limit() -> None:
    """Composite frame 35 (cropped): a dark red mark beside an orange board, measured in the
    search image. The measurement is right (r 34.1 of 34.05) but its outline error, 0.70 there,
    failed the full-resolution limit of 0.65; marks measured in the search image have their own
    limit (0.75). Since each pixel is read against the background that explains it best (not
    its sector's mean, which mixed board and wall), the board's edge no longer counts as half
    mark and the outline passes even 0.65."""
    image = _composite_crop("board-red-rocket.png")
    red = _only(Detector(PALETTE).detect(image), "red")
    assert math.hypot(red.x - 80.11, red.y - 70.28) < 3.0
    assert red.radius == pytest.approx(34.05, rel=0.03)
    strict = Detector(PALETTE, DetectorConfig(max_search_outline_error=0.65)).detect(image)
    assert [m for m in strict if m.colour == "red"], strict


def test_a_small_mark_beside_a_near_colour_board_is_measured_against_the_board() -> None:
    """Composite frame 32 (cropped): a blue mark (r 12.7) against a violet board on its right
    and a fruit's orange above. The sector above-right held both board and fruit: against that
    sector's mean colour the board's pixels there read as mark, the outline error was 1.0 and
    the mark was lost. Each pixel against the background that explains it best: found, radius
    within 3 %."""
    image = _composite_crop("board-blue-fruits.png")
    blue = _only(Detector(PALETTE).detect(image), "blue")
    assert math.hypot(blue.x - 59.58, blue.y - 60.06) < 1.0
    assert blue.radius == pytest.approx(12.68, rel=0.03)


def test_a_mark_against_a_board_of_its_palette_colour_with_a_pole_across_it() -> None:
    """Composite frame 44 (cropped): a blue mark (hue 115) with a violet board (hue 130, inside
    blue's range after the white balance) behind its left half and a lavender pole across it.
    The blob holds two hue clusters of one palette colour; the mark's cluster was cut out, but
    its readings still took the board's pixels for the mark going on past its outline
    ("continued" 0.46, and the search-resolution arc test's colour beyond the outline), and the
    mark was lost. The other cluster's pixels are another object now: found, within 1 px."""
    image = _composite_crop("board-pole-blue-messi.png")
    blue = _only(Detector(PALETTE).detect(image), "blue")
    assert math.hypot(blue.x - 95.76, blue.y - 95.88) < 1.0
    assert blue.radius == pytest.approx(38.8, abs=1.0)


def _faint_and_vivid() -> np.ndarray:
    """A grey wall with a dark, slightly blue disc (hue and saturation of the palette's blue,
    S ≈ 110, but little colour: a shadowed patch) and a vivid red one."""
    img = _scene(back=(120, 120, 120))
    _disc(img, 100.0, 120.0, 20.0, (80, 50, 45), "flat")
    _disc(img, 220.0, 120.0, 20.0, (40, 40, 230), "flat")
    return _finish(img)


def test_chroma_contrast_is_the_grey_free_colour_difference_to_the_ring() -> None:
    from marknav.vision.detect.faint import chroma_contrast

    frame = _faint_and_vivid()
    faint = Mark("blue", 100.0, 120.0, 20.0, (20.0, 20.0), 0.0, "circle", 0.9)
    vivid = Mark("red", 220.0, 120.0, 20.0, (20.0, 20.0), 0.0, "circle", 0.9)
    # The flat profile's mean light inside is 0.875: inside (70, 43.75, 39.4) against the wall's
    # (120, 120, 120); grey removed, |(18.9, -7.3, -11.7)| = 23.4.
    d = 0.875 * np.array([80.0, 50.0, 45.0]) - 120.0
    expected = float(np.linalg.norm(d - d.mean()))
    assert chroma_contrast(frame, faint, (1.0, 1.0, 1.0)) == pytest.approx(expected, abs=2.0)
    assert chroma_contrast(frame, vivid, (1.0, 1.0, 1.0)) > 120.0
    # The white balance's gains apply to the difference.
    assert chroma_contrast(frame, faint, (1.0, 1.0, 2.0)) > 2.0 * expected


def test_a_faint_round_blob_of_a_palette_hue_is_not_a_mark_a_vivid_one_is() -> None:
    frame = _faint_and_vivid()
    everything = Detector(PALETTE, DetectorConfig(min_chroma_contrast=0.0)).detect(frame)
    assert sorted(m.colour for m in everything) == ["blue", "red"], everything
    marks = Detector(PALETTE).detect(frame)
    assert [m.colour for m in marks] == ["red"], marks
    # In a dim scene the floor scales down with the grey level, as the value floors do: the
    # same frame at half the light keeps the red mark.
    dim = (frame.astype(np.float32) * 0.5).astype(np.uint8)
    assert [m.colour for m in Detector(PALETTE).detect(dim)] == ["red"]
    with pytest.raises(ValueError, match="min_chroma_contrast"):
        DetectorConfig(min_chroma_contrast=-1.0)


def test_the_blurred_crowd_of_messi5_gives_fewer_marks() -> None:
    """``tests/data/real/messi5.jpg`` at 640 px: out-of-focus shirts and a jersey patch of the
    palette's hues came out as marks (four of them, two thirds of the corpus's false marks,
    before a blob's other hue clusters counted as other objects; three since). The two
    faintest (chroma 25 and 33 against 44) are dropped."""
    from marknav.vision.detect.faint import chroma_contrast

    small = _photo_at_640("messi5.jpg")
    loose = Detector(PALETTE, DetectorConfig(min_chroma_contrast=0.0))
    everything = loose.detect(small)
    assert len(everything) >= 3, everything
    detector = Detector(PALETTE)
    kept = detector.detect(small)
    assert len(kept) <= len(everything) - 2, kept
    assert all(m in everything for m in kept)
    dropped = [m for m in everything if m not in kept]
    assert all(chroma_contrast(small, m, loose.last_gains) < 44.0 for m in dropped), dropped
