"""marknav: drive an iRobot Create past coloured circular marks with one camera.

Packages, bottom to top; each imports only those below it (``docs/architecture.md``):

- :mod:`marknav.core` — clock, errors and exit codes, signals, bounded file reading, YAML
- :mod:`marknav.planning` — Bézier bypass geometry, path tracking, differential-drive kinematics
- :mod:`marknav.vision` — mark detection, range/offset estimation, calibration, frame sources
- :mod:`marknav.robot` — Create Open Interface, serial transport, safety state machine, driver
- :mod:`marknav.remote` — the MJPEG camera server and the RFC 2217 serial bridge
- :mod:`marknav.sim` — simulated world, camera renderer, byte-level simulated Create, truth
- :mod:`marknav.missions` — the mission schema as data, loading, overrides, node registry
- :mod:`marknav.behaviours` — py_trees behaviours, the target tracker, tree building
- :mod:`marknav.testing` — fakes and pytest fixtures for users' own behaviour tests
- :mod:`marknav.runs` — run loop, environments, report, log, viewer, evaluate, tune, bench
- :mod:`marknav.cli` — one module per command; the only code that prints
"""

__version__ = "0.1.0"
