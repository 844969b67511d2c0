"""predgait.kinematics."""
