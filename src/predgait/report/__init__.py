"""predgait.report."""
