"""predgait.problems."""
