"""pytest plugin (registered through the ``pytest11`` entry point): marknav's fixtures.

Installing marknav makes these fixtures available to any test suite.
"""

from __future__ import annotations

import pytest

from marknav.clock import ManualClock


@pytest.fixture
def manual_clock() -> ManualClock:
    """A clock at t = 0 that moves only with ``advance(dt)``."""
    return ManualClock()
