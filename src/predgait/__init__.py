"""predgait: forward dynamic modelling of human walking.

Inverse dynamics (Pinocchio RNEA), forward synthesis (Pinocchio ABA), optimisation
(CasADi + Ipopt on ADAM dynamics) and what-if scenarios, after Rinehart's thesis
(see ARCHITECTURE.md).
"""

__version__ = "0.1.0"
