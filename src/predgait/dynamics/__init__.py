"""predgait.dynamics."""
