"""marknav: drive an iRobot Create past coloured circular marks with one camera.

Sub-packages (one idea each):

- :mod:`marknav.vision` — mark detection, frame sources, range/offset estimation, calibration
- :mod:`marknav.planning` — Bézier bypass geometry, path tracking, differential-drive kinematics
- :mod:`marknav.drivers` — Create Open Interface protocol, serial transport, safety state machine
- :mod:`marknav.sim` — simulated world, camera renderer, byte-level simulated Create
- :mod:`marknav.behaviours` — py_trees behaviours
- :mod:`marknav.missions` — mission schema, YAML loading, tree building, the run loop
- :mod:`marknav.testing` — fakes and pytest fixtures for users' own behaviour tests
"""

__version__ = "0.1.0"
