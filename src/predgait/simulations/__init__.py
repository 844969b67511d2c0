"""predgait.simulations: experiment set-ups built on the forward engine.

The rod (thesis 4.1), gait7 driven on its contacts and the whole body driven by its
inverse dynamics: each builds a model, its drivers and applied forces from measured or
synthetic input and runs the engine in ``predgait.dynamics``; no file output here
(``predgait.workflows`` writes result folders).
"""
