"""MarknavBehaviour.read/write: the storage fast path keeps py_trees' access rules and falls
back to the client (which records activity) when an activity stream is on."""

from __future__ import annotations

from collections.abc import Iterator
from typing import ClassVar

import py_trees
import pytest
from py_trees.common import Status

from marknav.behaviours import keys
from marknav.behaviours.base import MarknavBehaviour


class Probe(MarknavBehaviour):
    READS: ClassVar[tuple[str, ...]] = (keys.TARGET,)
    WRITES: ClassVar[tuple[str, ...]] = (keys.DRIVER,)

    def update(self) -> Status:
        return Status.SUCCESS


@pytest.fixture
def probe(blackboard: None) -> Iterator[Probe]:
    yield Probe("probe")
    py_trees.blackboard.Blackboard.disable_activity_stream()


@pytest.mark.parametrize("stream", [False, True])
def test_reads_and_writes_keep_the_access_rules(probe: Probe, stream: bool) -> None:
    bb = py_trees.blackboard.Blackboard
    if stream:
        bb.enable_activity_stream()
    assert probe.read(keys.TARGET, "none yet") == "none yet"  # unset: the default
    bb.set(keys.TARGET, None)
    assert probe.read(keys.TARGET, "none yet") is None  # set to None is not unset
    probe.write(keys.DRIVER, "me")
    assert bb.get(keys.DRIVER) == "me"
    assert probe.read(keys.DRIVER) == "me"  # write access includes reading
    with pytest.raises(AttributeError, match="does not have read/write access"):
        probe.read(keys.PLANS)
    with pytest.raises(AttributeError, match="does not have write access"):
        probe.write(keys.TARGET, "x")
    if stream:
        assert bb.activity_stream is not None
        kinds = [item.activity_type for item in bb.activity_stream.data]
        assert "INITIALISED" in kinds and "READ" in kinds  # the client recorded them
