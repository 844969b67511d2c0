"""numpy or CasADi: elementwise functions that accept both (for optimisation problems)."""

from __future__ import annotations


def is_casadi(*values) -> bool:
    """Whether any value is a CasADi SX/MX/DM (checked without importing casadi)."""
    return any(type(v).__module__.startswith("casadi") for v in values)
