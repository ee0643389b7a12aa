"""lagdsl: a compiler for Lagrangian mechanics.

    model = lagdsl.load("double_pendulum.lag")
    result = model.simulate("chaos")             # C backend; backend="numpy" for NumPy
    result["theta1"], result.t, result.summary.render(), result.to_csv("out.csv")
"""
__version__ = "0.1.0"

from .api import Model, load  # noqa: E402  (after __version__, which the code generators print)
from .errors import LagError, SimulationError  # noqa: E402
__all__ = ["load", "Model", "LagError", "SimulationError", "__version__"]
