"""The run's MCAP recording (ROS 2 messages), read back by other people's tools.

One short simulated slalom run writes its recording; ``rosbags`` (Jazzy typestore) reads the
rosbag2 folder and the bare file, ``mcap``'s own reader decodes every message, and Rerun
converts it. The frames the detector processed are caught as it processed them and compared
with the images in the file.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("mcap_ros2")
rosbags = pytest.importorskip("rosbags")

from marknav.missions.schema import load_mission  # noqa: E402
from marknav.runs.loop.run import RunRequest, execute  # noqa: E402
from marknav.runs.records import runlog  # noqa: E402
from marknav.runs.records.mcap_recording import (  # noqa: E402
    RECORD_HZ,
    TOPICS,
    TREE_SCHEMA,
    recording_folder_problem,
)
from marknav.runs.records.ros2_types import definition  # noqa: E402
from marknav.runs.records.runlog import Replay, read_log  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]
SLALOM = ROOT / "missions" / "slalom.yaml"
#: Mission time of the run, s: past the first bypass plan (the slalom's first is at ~6 s).
RUN_S = 9.0
EVERY_TICK = ("/tf", "/odom", "/cmd_vel", "/marknav/safety", "/marknav/tree")


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    folder = tmp_path_factory.mktemp("bag")
    seen: dict[int, np.ndarray] = {}  # frame index -> the image the detector processed
    original = runlog.Recorder._frames

    def spy(self: runlog.Recorder, now: float) -> list[tuple[dict[str, Any], Any]]:
        out = original(self, now)
        for fr, image in out:
            seen[int(fr["index"])] = image.copy()
        return out

    mp = pytest.MonkeyPatch()
    mp.setattr(runlog.Recorder, "_frames", spy)
    try:
        result = execute(RunRequest(
            mission=load_mission(str(SLALOM)), report_path=folder / "report.json",
            events_path=folder / "report.events.jsonl", record_path=folder / "run.mcap",
            max_time_s=RUN_S))
    finally:
        mp.undo()
    return {"folder": folder, "mcap": folder / "run.mcap", "result": result, "seen": seen,
            "records": read_log(folder / "report.events.jsonl")}


def _rosbags_messages(path: Path) -> list[tuple[str, int, Any]]:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    out = []
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        for con, t, raw in reader.messages():
            out.append((con.topic, t, reader.deserialize(raw, con.msgtype)))
    return out


@pytest.mark.slow
def test_rosbags_reads_every_topic_with_the_runs_counts(recorded: dict[str, Any]) -> None:
    report = recorded["result"].report
    frames = [r for r in recorded["records"] if r["kind"] == "frame"]
    for path in (recorded["folder"], recorded["mcap"]):  # the rosbag2 folder, the bare file
        counts = Counter(topic for topic, _, _ in _rosbags_messages(path))
        assert set(counts) == set(TOPICS), path
        for topic in EVERY_TICK:
            assert counts[topic] == report.ticks, topic
        assert counts["/marknav/marks/detected"] == len(frames) > 0
        images = counts["/camera/image/compressed"]
        assert images == counts["/camera/camera_info"] == counts["/camera/annotations"]
        assert RECORD_HZ * report.sim_time_s - 1 <= images <= RECORD_HZ * report.sim_time_s + 1
        # the static messages: at the start and once a second after
        assert counts["/tf_static"] == counts["/marknav/marks/world"] == (
            math.floor(report.sim_time_s) + 1)
        assert counts["/marknav/plans"] == len(recorded["result"].plans) > 0
    meta = (recorded["folder"] / "metadata.yaml").read_text()
    import yaml

    info = yaml.safe_load(meta)["rosbag2_bagfile_information"]
    assert info["relative_file_paths"] == ["run.mcap"]
    assert {t["topic_metadata"]["name"]: t["message_count"]
            for t in info["topics_with_message_count"]} == dict(counts)
    assert recording_folder_problem(recorded["mcap"]) is None
    assert "another recording" in str(recording_folder_problem(recorded["folder"] / "b.mcap"))


@pytest.mark.slow
def test_the_tf_tree_connects_world_odom_and_the_camera(recorded: dict[str, Any]) -> None:
    parent: dict[str, str] = {}
    poses = []
    for topic, _, msg in _rosbags_messages(recorded["mcap"]):
        if topic in ("/tf", "/tf_static"):
            for tf in msg.transforms:
                parent[tf.child_frame_id] = tf.header.frame_id
                if topic == "/tf" and tf.child_frame_id == "base_link":
                    poses.append(tf.transform)
    chain = ["camera_optical"]
    while chain[-1] in parent:
        chain.append(parent[chain[-1]])
    assert chain == ["camera_optical", "camera_link", "base_link", "odom", "world"]
    assert parent["base_link_truth"] == "world"
    # odometry in metres: the last transform is the run's last logged pose
    last = next(r for r in reversed(recorded["records"]) if r["kind"] == "tick")["pose"]
    t = poses[-1]
    assert t.translation.x == pytest.approx(last[0] / 1000.0)
    assert t.translation.y == pytest.approx(last[1] / 1000.0)
    assert 2.0 * math.atan2(t.rotation.z, t.rotation.w) == pytest.approx(last[2], abs=1e-6)


@pytest.mark.slow
def test_each_image_decodes_to_the_frame_the_detector_saw(recorded: dict[str, Any]) -> None:
    import cv2

    msgs = _rosbags_messages(recorded["mcap"])
    tree = next((t, m) for topic, t, m in msgs if topic == "/marknav/tree")
    start_ns = tree[0] - round(json.loads(tree[1].data)["t"] * 1e9)
    by_capture = {round(r["captured_t"], 4): r for r in recorded["records"]
                  if r["kind"] == "frame"}
    images = [m for topic, _, m in msgs if topic == "/camera/image/compressed"]
    infos = [m for topic, _, m in msgs if topic == "/camera/camera_info"]
    drawn = [m for topic, _, m in msgs if topic == "/camera/annotations"]
    assert images
    for img, info, notes in zip(images, infos, drawn, strict=True):
        stamp = img.header.stamp.sec * 1_000_000_000 + img.header.stamp.nanosec
        frame = by_capture[round((stamp - start_ns) / 1e9, 4)]
        seen = recorded["seen"][frame["index"]]
        got = cv2.imdecode(np.frombuffer(bytes(img.data), np.uint8), cv2.IMREAD_COLOR)
        assert img.format == "jpeg" and got.shape == seen.shape
        error = np.abs(got.astype(np.int16) - seen.astype(np.int16)).mean()
        assert error < 4.0  # JPEG at quality 70; another frame differs by tens
        assert info.header.stamp == img.header.stamp
        assert (info.width, info.height) == (seen.shape[1], seen.shape[0])
        assert info.header.frame_id == img.header.frame_id == "camera_optical"
        # the detections drawn on it: a circle and a label each, at the ellipse's centre
        assert len(notes.circles) == len(notes.texts) == len(frame["marks"])
        for circle, text, m in zip(notes.circles, notes.texts, frame["marks"], strict=True):
            assert circle.timestamp == img.header.stamp
            assert (circle.position.x, circle.position.y) == (m["x_px"] + 0.5, m["y_px"] + 0.5)
            assert circle.diameter == pytest.approx(sum(m["axes_px"]))
            assert text.text.startswith(m["colour"])


@pytest.mark.slow
def test_the_mcap_reader_decodes_the_tree_tick_by_tick(recorded: dict[str, Any]) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    trees, detected, world = [], [], None
    with open(recorded["mcap"], "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None
        for schema in summary.schemas.values():  # the definitions marknav ships, as stored
            assert schema.encoding == "ros2msg"
            assert schema.data.decode() == definition(schema.name)
        for _schema, channel, _message, msg in reader.iter_decoded_messages():
            if channel.topic == "/marknav/tree":
                trees.append(json.loads(msg.data))
            elif channel.topic == "/marknav/marks/detected":
                detected.append(msg.markers)
            elif channel.topic == "/marknav/marks/world" and world is None:
                world = msg.markers
    replay = Replay(recorded["records"])
    assert len(trees) == len(replay)
    for k, ((rec, state), tree) in enumerate(zip(replay.states(), trees, strict=True)):
        assert tree["schema"] == TREE_SCHEMA and tree["tick"] == rec["n"] == k
        assert [n["status"] for n in tree["nodes"]] == state.status, f"tick {k}"
        assert [n["message"] for n in tree["nodes"]] == state.message, f"tick {k}"
        assert [n["name"] for n in tree["nodes"]] == state.names
        assert tree["active"] == state.active_path()
        assert tree["panel"] == rec["panel"]
    # each frame's marks: a DELETEALL, then a disc and a range label per placed mark
    frames = [r for r in recorded["records"] if r["kind"] == "frame"]
    for fr, markers in zip(frames, detected, strict=True):
        placed = [m for m in fr["marks"] if "forward_mm" in m]
        assert markers[0].action == 3 and len(markers) == 1 + 2 * len(placed)
        for m, disc, label in zip(placed, markers[1::2], markers[2::2], strict=True):
            assert disc.pose.position.x == pytest.approx(m["forward_mm"] / 1000.0)
            assert disc.pose.position.y == pytest.approx(m["left_mm"] / 1000.0)
            assert label.text == f"{m['colour']} {m['range_mm'] / 1000.0:.2f} m"
    env = recorded["result"].environment
    assert world is not None
    discs = [m for m in world if m.ns == "marks"]
    assert len(discs) == len(env.world.marks)
    for disc, mark in zip(discs, env.world.marks, strict=True):
        assert (disc.pose.position.x, disc.pose.position.y) == pytest.approx(
            (mark.xy[0] / 1000.0, mark.xy[1] / 1000.0))


@pytest.mark.slow
def test_rerun_converts_the_recording(recorded: dict[str, Any], tmp_path: Path) -> None:
    pytest.importorskip("rerun")
    exe = shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))
    env = {**os.environ, "RERUN_ANALYTICS": "0"}
    out = tmp_path / "run.rrd"
    subprocess.run([exe, "mcap", "convert", str(recorded["mcap"]), "-o", str(out)],
                   check=True, capture_output=True, env=env, timeout=120)
    text = subprocess.run([exe, "rrd", "print", str(out)], check=True, capture_output=True,
                          text=True, env=env, timeout=120).stdout
    entities = defaultdict(int)
    for topic in TOPICS:
        entities[topic] = text.count(f" - {topic} - ")
    assert all(entities[t] > 0 for t in TOPICS), entities
    # Rerun decoded the ROS 2 types into its own: JPEG images, the camera, the transforms
    for component in ("EncodedImage:blob", "Pinhole:image", "Transform3D:translation"):
        assert component in text, component


@pytest.mark.parametrize(("argv", "says"), [
    (["--record", "run.rrd"], "--record: the recording's file name must end in .mcap"),
    (["--record-hz", "0"], "--record-hz: must be positive, got 0.0"),
    (["--record-quality", "101"], "--record-quality: must be in 0..100, got 101"),
    (["--foxglove", "70000"], "--foxglove: must be a port in 0..65535, got 70000"),
])
def test_bad_recording_options_exit_2_naming_them(
        argv: list[str], says: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from marknav.cli.main import main

    assert main(["run", str(SLALOM), "--tree", "none", "--report",
                 str(tmp_path / "r.json"), *argv]) == 2
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err
    assert not (tmp_path / "r.json").exists()  # refused before anything started


def test_a_folder_holding_another_bag_is_refused_before_the_run(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from marknav.cli.main import main

    (tmp_path / "metadata.yaml").write_text("rosbag2_bagfile_information:\n"
                                            "  relative_file_paths: [other.mcap]\n")
    assert main(["run", str(SLALOM), "--tree", "none", "--report", str(tmp_path / "r.json"),
                 "--record", str(tmp_path / "run.mcap")]) == 2
    err = capsys.readouterr().err
    assert "belongs to another recording" in err and "--record" in err
    assert not (tmp_path / "run.mcap").exists()


def test_a_port_in_use_exits_2_before_the_robot_moves(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("foxglove")
    import socket

    from marknav.cli.main import main

    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        code = main(["run", str(SLALOM), "--tree", "none", "--report", str(tmp_path / "r.json"),
                     "--foxglove", str(port)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert f"--foxglove: cannot serve on 127.0.0.1:{port}" in err and "Traceback" not in err
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["outcome"] == "aborted" and report["ticks"] == 0


@pytest.mark.slow
@pytest.mark.parametrize("signame", ["SIGINT", "SIGTERM"])
def test_a_signal_mid_run_leaves_a_complete_recording_of_every_tick(
        tmp_path: Path, signame: str) -> None:
    import signal
    import time

    from mcap.reader import make_reader

    proc = subprocess.Popen(
        [sys.executable, "-m", "marknav", "run", str(SLALOM), "--tree", "none", "--realtime",
         "--report", str(tmp_path / "report.json"), "--record"],
        cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    log_path = tmp_path / "report.events.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:  # the loop has ticked for a while
        if log_path.exists() and log_path.read_text().count('"kind": "tick"') > 40:
            break
        time.sleep(0.1)
    proc.send_signal(getattr(signal, signame))
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["outcome"] == "aborted" and report["ticks"] > 40
    with open(tmp_path / "run.mcap", "rb") as fh:
        summary = make_reader(fh).get_summary()  # written whole: the summary is there
    assert summary is not None and summary.statistics is not None
    counts = {summary.channels[k].topic: n
              for k, n in summary.statistics.channel_message_counts.items()}
    assert counts["/marknav/tree"] == counts["/tf"] == report["ticks"]
    assert (tmp_path / "metadata.yaml").is_file()


@pytest.mark.parametrize(("module", "argv", "extra"), [
    ("mcap_ros2", ["--record"], "marknav[record]"),
    ("foxglove", ["--foxglove"], "marknav[foxglove]"),
])
def test_without_the_extra_the_option_exits_2_naming_it(
        module: str, argv: list[str], extra: str, tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    from marknav.cli.main import main

    monkeypatch.setitem(sys.modules, module, None)  # import -> ImportError
    assert main(["run", str(SLALOM), "--report", str(tmp_path / "r.json"), *argv]) == 2
    err = capsys.readouterr().err
    assert f"pip install '{extra}'" in err and argv[0] in err and "Traceback" not in err
