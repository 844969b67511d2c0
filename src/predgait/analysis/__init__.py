"""predgait.analysis."""
