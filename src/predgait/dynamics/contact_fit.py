"""ADAMS IMPACT parameters that approximate Meglan's foot-floor law (thesis 2.3.1).

The thesis approximated Meglan's (1991) F(x, v) = a x^4 + b x^4 v "for the normal range
of penetration (1 cm) ... by minimizing the square of the difference of the two curves"
with the IMPACT law F = k x + c S(x; d) v, S = (x/d)^2 (3 - 2 x/d) for x < d, 1 beyond
(the ADAMS STEP; :class:`~predgait.dynamics.contact.ImpactContact`, exponent 1). Its
fitted numbers are missing from the thesis text, so they are recomputed here.

Over x in [0, D] and a velocity range symmetric about 0 the squared difference splits
into a stiffness part (k x - a x^4)^2 and a damping part (c S - b x^4)^2 v^2 (the cross
term is odd in v), fitted separately by linear least squares on a uniform grid of x.
For a given d the damping fit is linear in c; the error falls monotonically as d grows
(S tends to 3 (x/d)^2, a smaller misfit to x^4), so d is held at the top of the fit
range: d = D, where the thesis defines d as the depth at which damping reaches its full
value. Closed forms on [0, D]: k = a D^3 / 2 and, for d = D, c = (175/364) b D^4.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from predgait.dynamics.contact import ImpactContact, MeglanContact, adams_step
from predgait.errors import InputError


@dataclass(frozen=True)
class ImpactFit:
    """Least-squares IMPACT approximation of a Meglan law.

    Attributes:
        contact: The fitted :class:`ImpactContact` (k N/m, c N s/m, d m, exponent 1).
        depth: Fit range D, m.
        stiffness_rms: RMS of k x - a x^4 over [0, D], N.
        damping_rms: RMS of c S(x) - b x^4 over [0, D], N s/m.
    """

    contact: ImpactContact
    depth: float
    stiffness_rms: float
    damping_rms: float


def fit_impact_to_meglan(meglan: MeglanContact | None = None, *, depth: float = 0.01,
                         samples: int = 2001) -> ImpactFit:
    """Fit IMPACT k, c (d = ``depth``) to ``meglan`` over penetrations 0..``depth`` (m)."""
    meglan = MeglanContact() if meglan is None else meglan
    if not 1e-4 <= depth <= 0.1:
        raise InputError(f"contact fit depth {depth:g} m is outside 0.0001..0.1 m.")
    x = np.linspace(0.0, depth, samples)
    spring, damper = meglan.a * x**4, meglan.b * x**4
    k = float(x @ spring / (x @ x))
    step = adams_step(x, 0.0, 0.0, depth, 1.0)
    c = float(step @ damper / (step @ step))
    contact = ImpactContact(stiffness=k, exponent=1.0, damping=c, damping_depth=depth)
    return ImpactFit(contact=contact, depth=depth,
                     stiffness_rms=float(np.sqrt(np.mean((k * x - spring) ** 2))),
                     damping_rms=float(np.sqrt(np.mean((c * step - damper) ** 2))))
