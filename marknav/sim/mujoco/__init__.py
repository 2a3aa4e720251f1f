"""MuJoCo as a second simulator engine (the ``mujoco`` extra): physics, contacts and rendering.

- :mod:`~marknav.sim.mujoco.gl`: headless OpenGL (OSMesa) and a clear error without it;
- :mod:`~marknav.sim.mujoco.model`: a marknav world as MJCF, with a Create 2;
- :mod:`~marknav.sim.mujoco.body`: the Create's body in MuJoCo, a
  :class:`marknav.sim.simulated_create.Body` under the simulated Create's Open Interface;
- :mod:`~marknav.sim.mujoco.camera`: MuJoCo's renderer as the robot's camera;
- :mod:`~marknav.sim.mujoco.scene`: the MuJoCo-only room (lights, textures, occluders,
  distractors) and its randomisation.

Nothing imports ``mujoco`` until an engine is built, so marknav works without the extra.
"""
