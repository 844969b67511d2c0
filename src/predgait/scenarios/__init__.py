"""predgait.scenarios."""
