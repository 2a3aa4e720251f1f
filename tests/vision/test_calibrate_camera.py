"""``marknav calibrate-camera`` on OpenCV's own chessboard samples, and its bad inputs."""

from __future__ import annotations

import json
import re
from pathlib import Path

import cv2
import pytest

from marknav.cli.main import main

DATA = Path(__file__).resolve().parents[1] / "data"
LEFT = sorted(str(p) for p in (DATA / "opencv-left").glob("left*.jpg"))


def _reference() -> tuple[float, float, float, float]:
    fs = cv2.FileStorage(str(DATA / "opencv-left" / "left_intrinsics.yml"),
                         cv2.FILE_STORAGE_READ)
    k = fs.getNode("camera_matrix").mat()
    fs.release()
    return float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2])


def test_opencv_samples_match_opencvs_reference(capsys: pytest.CaptureFixture[str]) -> None:
    assert len(LEFT) == 13  # left10 is missing from OpenCV's set
    assert main(["calibrate-camera", *LEFT, "--board", "9x6", "--square-mm", "25",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for got, ref in zip((out["fx"], out["fy"], out["cx"], out["cy"]), _reference(),
                        strict=True):
        assert got == pytest.approx(ref, rel=0.01)
    assert 0.1 < out["rms"] < 1.0
    assert len(out["dist"]) == 5 and out["dist"][0] < -0.2  # clear barrel distortion
    assert out["images_used"] == LEFT


def test_text_output_has_k_rms_and_a_block_to_paste(capsys: pytest.CaptureFixture[str],
                                                     tmp_path: Path) -> None:
    plot = tmp_path / "cal.png"
    assert main(["calibrate-camera", *LEFT[:5], "--board", "9x6", "--square-mm", "25",
                 "--plot", str(plot)]) == 0
    out = capsys.readouterr().out
    assert re.search(r"RMS reprojection error = 0\.\d{4} px", out)
    line = next(x for x in out.splitlines() if x.startswith("intrinsics:"))
    import yaml

    block = yaml.safe_load(line)["intrinsics"]
    assert set(block) == {"fx", "fy", "cx", "cy", "dist"}
    assert block["fx"] == pytest.approx(_reference()[0], rel=0.03)
    assert plot.stat().st_size > 10_000


def _fails(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    assert main(["calibrate-camera", *argv]) == 2
    return capsys.readouterr().err


def test_bad_inputs_exit_2_naming_the_file(capsys: pytest.CaptureFixture[str],
                                           tmp_path: Path) -> None:
    board = ["--board", "9x6", "--square-mm", "25"]
    smarties = str(DATA / "smarties.png")
    err = _fails(capsys, LEFT[0], smarties, LEFT[1], *board)
    assert f"{smarties}: no 9x6 chessboard found" in err
    err = _fails(capsys, LEFT[0], LEFT[1], *board)
    assert "need at least 3 images" in err
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), cv2.resize(cv2.imread(LEFT[2]), (320, 240)))
    err = _fails(capsys, LEFT[0], LEFT[1], str(small), *board)
    assert f"{small}: image is 320x240, but {LEFT[0]} is 640x480" in err
    junk = tmp_path / "junk.jpg"
    junk.write_text("not a JPEG\n")
    err = _fails(capsys, LEFT[0], str(junk), LEFT[1], *board)
    assert f"{junk}: cannot read the image" in err
    err = _fails(capsys, LEFT[0], str(tmp_path / "missing.jpg"), LEFT[1], *board)
    assert "missing.jpg: no such file" in err
    err = _fails(capsys, *LEFT[:3], "--board", "9by6", "--square-mm", "25")
    assert "--board: expected COLSxROWS" in err
    assert "Traceback" not in err


def test_opencv_yml_is_read_back_by_opencv(capsys: pytest.CaptureFixture[str],
                                           tmp_path: Path) -> None:
    out = tmp_path / "left.yml"
    assert main(["calibrate-camera", *LEFT, "--board", "9x6", "--square-mm", "25", "--json",
                 "--opencv-yml", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out)
    fs = cv2.FileStorage(str(out), cv2.FILE_STORAGE_READ)
    assert fs.isOpened()
    k = fs.getNode("camera_matrix").mat()
    dist = fs.getNode("distortion_coefficients").mat()
    width = fs.getNode("image_width").real()
    height = fs.getNode("image_height").real()
    rms = fs.getNode("avg_reprojection_error").real()
    per_view = fs.getNode("per_view_reprojection_errors").mat()
    fs.release()
    assert k.shape == (3, 3) and dist.shape == (5, 1)
    assert (k[0, 0], k[1, 1], k[0, 2], k[1, 2]) == pytest.approx(
        (printed["fx"], printed["fy"], printed["cx"], printed["cy"]), rel=1e-12)
    assert k[2, 2] == 1.0 and k[0, 1] == 0.0
    assert dist.ravel().tolist() == pytest.approx(printed["dist"], rel=1e-12)
    assert (width, height) == (640, 480)
    assert rms == pytest.approx(printed["rms"], rel=1e-12)
    assert per_view.shape == (13, 1)
    # OpenCV's own reference for these images agrees with what was written
    assert k[0, 0] == pytest.approx(_reference()[0], rel=0.01)


def test_opencv_yml_to_a_missing_folder_fails_before_calibrating(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bad = tmp_path / "no" / "such" / "left.yml"
    err = _fails(capsys, *LEFT[:3], "--board", "9x6", "--square-mm", "25",
                 "--opencv-yml", str(bad))
    assert f"{bad}" in err and "--opencv-yml" in err and "does not exist" in err
