"""pytest plugin (registered through the ``pytest11`` entry point): marknav's fixtures.

Installing marknav makes these fixtures available to any test suite: ``manual_clock``,
``fake_robot``, ``fake_perception``, ``blackboard``, ``mission_factory`` and ``tree_coverage``
(see :mod:`marknav.testing`). The heavier imports happen inside the fixtures, so merely having
marknav installed costs other test suites nothing.

``pytest --marknav-coverage`` counts every behaviour-tree tick of the session
(:mod:`marknav.testing.coverage`) and prints, at the end, each node's ticks and outcomes and the
nodes no test reached.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any

import pytest

from marknav.core.clock import ManualClock

if TYPE_CHECKING:
    from marknav.missions.schema import Mission
    from marknav.testing.coverage import TreeCoverage
    from marknav.testing.perception import FakePerception
    from marknav.testing.robot import FakeRobot


@pytest.fixture
def manual_clock() -> ManualClock:
    """A clock at t = 0 that moves only with ``advance(dt)``."""
    return ManualClock()


@pytest.fixture
def fake_robot(manual_clock: ManualClock) -> FakeRobot:
    """A :class:`~marknav.testing.FakeRobot` on ``manual_clock``: connected (``ready``), at the
    origin facing +y, wheel base 235 mm, the real safety layer with 0.3 s / 0.2 s watchdogs."""
    from marknav.testing.robot import FakeRobot

    return FakeRobot(clock=manual_clock)


@pytest.fixture
def fake_perception() -> FakePerception:
    """A :class:`~marknav.testing.FakePerception` named ``Perception``, with no marks yet:
    ``fake_perception.place("red", x_mm=0, y_mm=1500)`` puts one in the world."""
    from marknav.testing.perception import FakePerception

    return FakePerception()


@pytest.fixture
def blackboard() -> Iterator[None]:
    """py_trees' blackboard is process-global: cleared before and after the test."""
    import py_trees

    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


@pytest.fixture
def mission_factory() -> Callable[..., Mission]:
    """:func:`marknav.testing.make_mission`: a minimal valid mission (route red, green, red), with
    overrides merged in: ``mission_factory(route=["blue"], navigation={"clearance_mm": 350})``."""
    from marknav.testing.missions import make_mission

    def factory(**overrides: Any) -> Mission:
        return make_mission(**overrides)

    return factory


# --- tree coverage ----------------------------------------------------------------------------

_SESSION_KEY = pytest.StashKey["TreeCoverage"]()


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.getgroup("marknav").addoption(
        "--marknav-coverage", action="store_true", default=False,
        help="count the behaviour-tree nodes every test ticks, with their outcomes; print a "
             "summary (and the nodes never reached) at the end")


def pytest_sessionstart(session: pytest.Session) -> None:
    if session.config.getoption("--marknav-coverage", default=False):
        from marknav.testing.coverage import TreeCoverage

        session.config.stash[_SESSION_KEY] = TreeCoverage().start()


def pytest_terminal_summary(terminalreporter: Any, exitstatus: int,
                            config: pytest.Config) -> None:
    coverage = config.stash.get(_SESSION_KEY, None)
    if coverage is None:
        return
    coverage.stop()
    terminalreporter.section("marknav tree coverage")
    if not coverage.nodes:
        terminalreporter.write_line("no behaviour tree was ticked")
        return
    for line in coverage.report():
        terminalreporter.write_line(line)
    never = coverage.never_ticked()
    leaves = [c for c in coverage.nodes.values() if c.kind == "leaf" and c.ticks]
    terminalreporter.write_line(
        f"{len(coverage.nodes)} nodes, {len(never)} never ticked; "
        f"{sum(1 for c in leaves if not c.statuses['FAILURE'])} of {len(leaves)} ticked leaves "
        "never failed")


@pytest.fixture
def tree_coverage() -> Iterator[TreeCoverage]:
    """A :class:`~marknav.testing.coverage.TreeCoverage` of the test's own ticks:
    ``tree_coverage.outcomes("Bypass") == {"RUNNING", "SUCCESS"}``,
    ``tree_coverage.never_ticked()``."""
    from marknav.testing.coverage import TreeCoverage

    coverage = TreeCoverage().start()
    yield coverage
    coverage.stop()
