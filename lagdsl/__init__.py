"""lagdsl: a compiler for Lagrangian mechanics.

    model = lagdsl.load("double_pendulum.lag")
    result = model.simulate("chaos")             # C backend; backend="numpy" for NumPy
    result["theta1"], result.t, result.summary.render(), result.to_csv("out.csv")
"""
__version__ = "0.1.0"

from .errors import LagError, SimulationError  # noqa: E402  (after __version__, which the code generators print)

__all__ = ["load", "Model", "LagError", "SimulationError", "__version__"]


def __getattr__(name: str):
    """`load` and `Model` on first use, with numpy: a warm `lagc run` (run/plans.py) does
    without the Python API; sympy and lark come with the first model parsed and derived."""
    if name in ("load", "Model"):
        from . import api
        return getattr(api, name)
    raise AttributeError(f"module 'lagdsl' has no attribute '{name}'")
