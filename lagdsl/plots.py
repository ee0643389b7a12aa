"""Figures as PNG bytes (matplotlib, Agg backend: no display needed): the work-precision diagram
of `lagc bench --plot`, the outputs of `lagc run --plot` and the mode shapes of `lagc modes --plot`."""
from __future__ import annotations

import io
import math

import numpy as np

from .errors import LagError, Setting
from .integrators import registry

EXTRA = "plots"         # the optional dependencies in pyproject.toml that bring matplotlib


def require_matplotlib() -> None:
    """matplotlib is optional: `--plot` without it is refused before any work, naming the extra."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise LagError(f"drawing a plot needs matplotlib, which is not installed: pip install 'lagdsl[{EXTRA}]'",
                       Setting("--plot")) from None


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as pyplot
    return pyplot


def _png(figure) -> bytes:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110)
    _pyplot().close(figure)
    return buffer.getvalue()


def work_precision_png(report) -> bytes:
    """Left: error against integration time, log-log, one line per integrator and backend, the
    reference's accuracy as a dashed line (points on it are at or below it, not measured).
    Right: I(t) - I(t0) of each conserved quantity for each method's tightest setting."""
    pyplot = _pyplot()
    panels = 2 if report.drifts else 1
    figure, axes = pyplot.subplots(1, panels, figsize=(6.5 * panels, 5), squeeze=False)
    diagram = axes[0][0]
    lines: dict[str, list] = {}
    for row in report.rows:          # in ladder order, loosest first: the line follows the ladder
        if row.failure is None and row.seconds:
            lines.setdefault(row.setting.method, []).append(row)
    colors = _method_colors(sorted(lines))
    for method, rows in sorted(lines.items()):
        peer = not registry.known(rows[0].setting.integrator)
        diagram.loglog([r.seconds for r in rows], [r.error for r in rows], marker="o" if not peer else "s",
                       linestyle="--" if peer else "-", markersize=4, label=method, color=colors[method])
    diagram.axhline(report.reference.accuracy, color="grey", linestyle=":", linewidth=1,
                    label="reference accuracy")
    diagram.set_xlabel("integration time [s]")
    diagram.set_ylabel("max abs error over rows and columns")
    diagram.set_title(f"{report.model}, scene {report.scene}: work against precision", fontsize=10)
    diagram.grid(True, which="major", alpha=0.3)
    diagram.legend(fontsize=7)
    if report.drifts:
        _drift_panel(axes[0][1], report.drifts, colors)
    figure.tight_layout()
    return _png(figure)


def _method_colors(methods: list[str]) -> dict:
    """One colour per method, the same in both panels: tab10, or tab20 for more than ten methods."""
    import matplotlib
    palette = matplotlib.colormaps["tab10" if len(methods) <= 10 else "tab20"]
    return {method: palette(index % palette.N) for index, method in enumerate(methods)}


def _drift_panel(axis, drifts, colors: dict) -> None:
    """|I(t) - I(t0)| on a log scale (zeros, at the start, left out)."""
    for drift in drifts:
        for number, (name, values) in enumerate(drift.drifts):
            magnitude = np.abs(values)
            shown = magnitude > 0
            axis.semilogy(drift.t[shown], magnitude[shown], linewidth=0.8, color=colors.get(drift.setting.method, "black"),
                          linestyle=("-", "--", ":", "-.")[number % 4],
                          label=f"{name}: {drift.setting.describe()}")
    axis.set_xlabel("t")
    axis.set_ylabel("|I(t) - I(t0)|")
    axis.set_title("drift of the conserved quantities, tightest setting of each method", fontsize=10)
    axis.grid(True, alpha=0.3)
    axis.legend(fontsize=6)


def outputs_png(result, title: str) -> bytes:
    """The output columns against t, one panel per column."""
    pyplot = _pyplot()
    count = max(1, len(result.columns))
    columns = 1 if count <= 3 else 2
    rows = math.ceil(count / columns)
    figure, axes = pyplot.subplots(rows, columns, figsize=(6.5 * columns, 2.2 * rows + 0.8), squeeze=False,
                                   sharex=True)
    for index, name in enumerate(result.columns):
        axis = axes[index // columns][index % columns]
        axis.plot(result.t, result[name], linewidth=1)
        axis.set_ylabel(name)
        axis.grid(True, alpha=0.3)
    for index in range(len(result.columns), rows * columns):
        axes[index // columns][index % columns].set_visible(False)
    for axis in axes[-1]:
        axis.set_xlabel("t")
    figure.suptitle(title, fontsize=10)
    figure.tight_layout()
    return _png(figure)


def mode_shapes_png(modes, title: str, count: int = 10) -> bytes:
    """The shapes of the `count` lowest modes (linear/modes.py), one panel each: every
    coordinate's amplitude (the real part of the shape scaled to a largest entry of 1; the
    modulus dashed where the shape is complex), the frequency and the verdict above it."""
    pyplot = _pyplot()
    shown = modes.modes[:max(1, count)]
    columns = 1 if len(shown) <= 3 else 2
    rows = math.ceil(len(shown) / columns)
    figure, axes = pyplot.subplots(rows, columns, figsize=(6.5 * columns, 1.9 * rows + 0.9), squeeze=False,
                                   sharex=True)
    positions = np.arange(len(modes.coordinates))
    marker = "o" if len(positions) <= 40 else None
    for index, mode in enumerate(shown):
        axis = axes[index // columns][index % columns]
        axis.axhline(0, color="0.6", linewidth=0.6)
        axis.plot(positions, mode.shape.real, marker=marker, linewidth=1)
        if np.any(np.abs(mode.shape.imag) > 1e-12):
            axis.plot(positions, np.abs(mode.shape), linestyle="--", linewidth=0.8, color="0.4")
        axis.set_ylim(-1.1, 1.1)
        axis.set_title(f"mode {index + 1}: {mode.omega:.6g} rad/s, {mode.verdict}", fontsize=9)
        axis.grid(True, alpha=0.3)
    for index in range(len(shown), rows * columns):
        axes[index // columns][index % columns].set_visible(False)
    for axis in axes[-1]:
        if len(positions) <= 12:
            axis.set_xticks(positions, modes.coordinates, rotation=30, fontsize=8)
        else:
            axis.set_xlabel("coordinate (in the model's order)")
    figure.suptitle(title, fontsize=10)
    figure.tight_layout()
    return _png(figure)


def fit_png(fit) -> bytes:
    """`lagc fit --plot`: per fitted column, the data (points) and the fitted model (line) above,
    the residuals (model - data) below."""
    pyplot = _pyplot()
    columns = [c for c in fit.fitted if c != "t"]
    figure, axes = pyplot.subplots(2, len(columns), figsize=(6 * len(columns), 6), squeeze=False, sharex="col",
                                   gridspec_kw={"height_ratios": (3, 1)})
    t = fit.fitted["t"]
    for k, column in enumerate(columns):
        top, bottom = axes[0][k], axes[1][k]
        top.plot(t, fit.fitted[column] - fit.residuals[column], ".", markersize=3, label="data")
        top.plot(t, fit.fitted[column], "-", label="fitted model")
        top.set_ylabel(column)
        top.legend()
        bottom.plot(t, fit.residuals[column], ".", markersize=3)
        bottom.axhline(0.0, color="black", linewidth=0.5)
        bottom.set_xlabel("t")
        bottom.set_ylabel("model - data")
    figure.suptitle(", ".join(f"{n} = {fit.values[n]:.6g} ± {fit.stderr[n]:.2g}" for n in fit.names))
    figure.tight_layout()
    return _png(figure)
