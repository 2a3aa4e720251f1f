"""Running and evaluating missions: the control loop, environments, the run report and log,
the live view, the Rerun viewer, evaluation and benchmarks (above marknav.missions,
the mission data)."""
