"""Random whole-body tracking data on a few nodes: points at which the tracking NLP's own
derivatives are compared with CasADi's (tests/test_fullbody_tracking*.py)."""

import numpy as np

from predgait.problems.fullbody_tracking import TrackingData


def random_tracking_data(model, n: int = 4, seed: int = 3) -> tuple[TrackingData, object]:
    """(data, rng): n nodes at 60 Hz, joints within 0.3 rad of the model's neutral pose, a
    random pelvis orientation, random rates, contacts, plate forces and torques; ``rng``
    (NumPy Generator) continues the same stream for the caller's own draws."""
    rng = np.random.default_rng(seed)
    q = np.tile(model.neutral(), (n, 1))
    q[:, 7:] += rng.uniform(-0.3, 0.3, (n, 29))
    q[:, 3:7] = rng.normal(size=(n, 4))
    q[:, 3:7] /= np.linalg.norm(q[:, 3:7], axis=1, keepdims=True)
    data = TrackingData(np.arange(n) / 60.0, q, rng.normal(size=(n, 35)),
                        rng.normal(size=(n, 35)), rng.random((n, 4)) < 0.6,
                        rng.normal(300, 50, (n, 2, 3)), rng.normal(0, 0.1, (n, 2, 3)),
                        rng.normal(size=(n, 2)), ground_z=0.0, belt_velocity=0.3,
                        tau=rng.normal(0, 50, (n, 29)))
    return data, rng
