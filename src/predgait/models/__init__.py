"""predgait.models."""
