"""A JPEG cut short (no end-of-image marker at its end) is named: OpenCV 5 refuses to decode it
and the error says it is truncated; where the decoder makes up the rest (OpenCV 4, silently) one
warning through logging names the file or stream, once per name."""

from __future__ import annotations

import logging
from typing import Any

import cv2
import numpy as np
import pytest

from marknav.core.errors import InputError
from marknav.vision import imagefile
from marknav.vision.imagefile import decode_image


def jpeg() -> bytes:
    """A whole 160 × 120 JPEG."""
    x = np.linspace(0, 255, 160, dtype=np.uint8)
    image = np.dstack([np.tile(x, (120, 1))] * 3)
    ok, buf = cv2.imencode(".jpg", image)
    assert ok
    data = buf.tobytes()
    assert data.endswith(b"\xff\xd9")
    return data


def warnings(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records
            if r.name == imagefile.__name__ and r.levelno == logging.WARNING]


def test_a_cut_jpeg_is_refused_as_truncated_or_decoded_with_one_named_warning(
        caplog: pytest.LogCaptureFixture) -> None:
    cut = jpeg()[:-200]
    caplog.set_level(logging.DEBUG, logger=imagefile.__name__)
    try:
        image = decode_image(cut, "frames/cut-0001.jpg")
    except InputError as exc:  # OpenCV 5 refuses to decode it
        assert str(exc) == ("frames/cut-0001.jpg: cannot decode the JPEG image (truncated: no "
                            "end-of-image marker at its end)")
        assert warnings(caplog) == []
    else:  # OpenCV 4 makes up the rows after the cut
        assert image.shape == (120, 160, 3)
        assert warnings(caplog) == [
            "frames/cut-0001.jpg: truncated JPEG (no end-of-image marker at its end): the "
            "decoder made up the image after the cut"]


def test_where_the_decoder_makes_up_the_rest_each_name_is_warned_about_once(
        monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    # OpenCV 4's behaviour, whatever OpenCV is installed: the cut frame decodes
    def made_up(buf: Any, flags: int) -> np.ndarray[Any, Any]:
        return np.zeros((120, 160, 3), np.uint8)

    monkeypatch.setattr(imagefile.cv2, "imdecode", made_up)
    monkeypatch.setattr(imagefile, "_WARNED_CUT", set())
    caplog.set_level(logging.DEBUG, logger=imagefile.__name__)
    cut = jpeg()[:-200]
    for _ in range(3):  # a stream whose frames all arrive cut
        decode_image(cut, "http://cam.local/video")
    decode_image(cut, "frames/0002.jpg")
    decode_image(jpeg(), "frames/0003.jpg")
    decode_image(jpeg() + b"\x00" * 16, "frames/0004.jpg")  # NUL padding after the marker
    said = warnings(caplog)
    assert len(said) == 2, said
    assert said[0].startswith("http://cam.local/video: truncated JPEG")
    assert said[1].startswith("frames/0002.jpg: truncated JPEG")
    assert sum("http://cam.local/video" in r.getMessage() for r in caplog.records) == 3


def test_a_whole_jpeg_decodes_without_a_word(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG, logger=imagefile.__name__)
    assert decode_image(jpeg() + b"\x00" * 16, "padded.jpg").shape == (120, 160, 3)
    assert caplog.records == []
