"""Fakes and pytest fixtures for testing behaviours with mocked perception."""

from marknav.clock import ManualClock

__all__ = ["ManualClock"]
