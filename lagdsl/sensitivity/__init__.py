"""Forward sensitivities of a run and the fit of parameters to measured data.

    names ──run.directions──▶ Directions (parameters, start values)
    scene ──lowering──▶ Kernel with Dp = ∂R/∂p, Cy, Cp, S0 ──run.integrate──▶ SensitivityResult
    data ──fit──▶ Fit (least squares with the sensitivities as the Jacobian)

api.Model.simulate(sensitivities=...) and api.Model.fit, and `lagc fit` (cli/fit.py), are built
on these.
"""
