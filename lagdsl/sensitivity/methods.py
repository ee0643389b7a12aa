"""What api.Model offers from this package beyond simulate(sensitivities=...) and fit: the
Lyapunov exponents, as a base class of Model, so that the Model class stays a readable size."""
from __future__ import annotations


class LyapunovMethod:
    """Model.lyapunov; the class it is mixed into has `plan`, `_sensitivity_programs` (the
    generated functions of sensitivity/run.py, by scene) and the rest of api.Model."""

    def lyapunov(self, scene: str | None = None, *, stop: float | None = None, all: bool = False,
                 renormalise: float | None = None, set: dict | None = None, start: float | None = None,
                 integrator: str | None = None, backend: str = "numpy", progress=None, **options):
        """The largest Lyapunov exponent of a scene's motion, or with `all` the whole spectrum
        (Benettin's QR method on the generated variational equations, on `backend`: "numpy", or
        "c" for the scene's C integrator; a constrained model's on its constraint manifold), over the
        scene's time span (`start`, `stop` override it: seconds, or "2 min"), re-orthonormalised
        every `renormalise` seconds (default 1); `set`, `integrator` and `options` (rtol, atol,
        max_step) as in simulate; `progress(t reached, start, stop)` is called at each
        re-orthonormalisation (a lagdsl.progress.TimeProgress draws a bar). Returns a
        sensitivity.lyapunov.Spectrum (.exponents in 1/s, .running against .times, .growth: the
        fit that separates exponential from algebraic growth, .hamiltonian, .render(), .to_csv())."""
        from ..api import single_number
        from ..model_runs import check_backend
        from ..errors import LagError
        from ..frontend.units import time_in_seconds
        from ..settings import RUN_OPTIONS, Overrides, given_options
        from . import lyapunov, run as sensitivity
        check_backend(backend)
        unknown = [name for name in options if name not in RUN_OPTIONS]
        if unknown:
            raise LagError(f"lyapunov: unknown option '{unknown[0]}' (options: {', '.join(RUN_OPTIONS)})")
        overrides = Overrides(tuple((k, single_number(k, v)) for k, v in (set or {}).items()),
                              time_in_seconds(start, "start"), time_in_seconds(stop, "stop"), None, integrator,
                              given_options(options))
        scene_plan = self.plan(scene, overrides)
        if scene_plan.scene_name not in self._sensitivity_programs:
            self._sensitivity_programs[scene_plan.scene_name] = sensitivity.build(self, scene)
        return lyapunov.lyapunov(self, self._sensitivity_programs[scene_plan.scene_name], scene_plan, all,
                                 renormalise, progress, backend)
