"""The NumPy backend's fixed-step integrators (rk4, gauss) and the Gauss-Legendre coefficients."""
from .fixed_step import IntegrationFailure, integrate_gauss, integrate_rk4
from .gauss_coefficients import gauss_legendre_tableau

__all__ = ["IntegrationFailure", "gauss_legendre_tableau", "integrate_gauss", "integrate_rk4"]
