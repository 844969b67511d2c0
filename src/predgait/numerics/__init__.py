"""Numerical building blocks below every other layer (NumPy only at import).

:mod:`~predgait.numerics.spline` (the not-a-knot cubic spline of gap filling and of the
drivers) and :mod:`~predgait.numerics.lsq` (the bounded linear least-squares step of
the IK and of the Gauss-Newton fits). They import nothing from predgait.
"""
