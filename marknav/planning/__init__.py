"""Planning: Bézier bypass geometry, path tracking, differential-drive kinematics (pure functions)."""
