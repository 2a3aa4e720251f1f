"""An image whose header lies (issue 15, item 13): a PNG claiming a huge size is refused
before decoding, by every command that reads an image.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import pytest

from marknav.cli.main import main
from tests.faultkit import SLALOM


def _png_claiming(width: int, height: int) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(
            ">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(
        b"\0" * 300)) + chunk(b"IEND", b""))


@pytest.mark.parametrize("claim", [(100_000, 100_000), (30_000, 30_000)])
def test_an_image_claiming_a_huge_size_is_refused_before_decoding(
        tmp_path: Path, claim: tuple[int, int], capsys: pytest.CaptureFixture[str]) -> None:
    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(_png_claiming(*claim))
    assert bomb.stat().st_size < 400
    for argv in (["detect", str(bomb)],
                 ["run", str(SLALOM), "--robot", "socket://127.0.0.1:9", "--camera", str(bomb),
                  "--report", str(tmp_path / "r.json")],
                 ["serve-camera", "--camera", str(bomb), "--port", "0"]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert f"{bomb}: PNG header claims {claim[0]} × {claim[1]} pixels" in err, argv
