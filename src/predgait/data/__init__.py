"""predgait.data."""
