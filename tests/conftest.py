"""Suite-wide settings.

Hypothesis's per-example deadline (200 ms by default) is a wall-clock assertion: on a loaded
machine a correct example can exceed it (``test_sample_spacing`` did). The tests assert
behaviour; speed is measured by ``marknav bench``. So no deadline, anywhere in the suite.
"""

from hypothesis import settings

settings.register_profile("marknav", deadline=None)
settings.load_profile("marknav")
