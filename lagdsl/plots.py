"""Figures as PNG bytes (matplotlib, Agg backend: no display needed): the outputs of a run against
t (`lagc run --plot`, `Result.plot`), a trajectory y against x (`--plot-xy x,y`,
`Result.plot(xy=...)`), the work-precision diagram of `lagc bench --plot` and the mode shapes of
`lagc modes --plot`.

Every figure is titled with the model and the scene, and every axis carries its unit as the model
declares or infers it (a column is plotted in the unit it is written in). Tick labels are plain
numbers, scaled by a power of ten where needed, never shifted by an additive offset: a column
that barely changes (a conserved energy) is plotted as its change from its first value, which the
panel's title gives.
"""
from __future__ import annotations

import io
import math

import numpy as np

from .errors import LagError, Setting
from .integrators import registry

RELATIVE_CHANGE_SHOWN = 1e-6     # below this, a column's ticks would all read alike: plot its change
LABEL_WIDTH = 22                 # characters of a panel's y label on one line
LEGEND_BELOW = dict(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), frameon=False)   # off the data
LINE_STYLES = ("-", "--", ":", "-.")
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


def close(figure) -> None:
    _pyplot().close(figure)


def _png(figure) -> bytes:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110, bbox_inches="tight")      # legends outside the axes
    close(figure)
    return buffer.getvalue()


def labelled(name: str, unit: str | None, width: int = 1000) -> str:
    """`theta [rad]`, or the bare name where the unit is not known; the unit on a line of its own
    when the label is longer than `width` characters."""
    if not unit or unit == "?":
        return name
    return f"{name} [{unit}]" if len(name) + len(unit) + 3 <= width else f"{name}\n[{unit}]"


def _plain_ticks(axis) -> None:
    """Tick labels without an additive offset (no `1e-24+1.878e-13`); a power of ten beside the
    axis where the numbers are very large or small."""
    from matplotlib.ticker import ScalarFormatter
    for which in (axis.xaxis, axis.yaxis):
        if which.get_scale() == "linear":
            formatter = ScalarFormatter(useOffset=False, useMathText=True)
            formatter.set_powerlimits((-3, 4))
            which.set_major_formatter(formatter)


def _shown(values: np.ndarray) -> tuple[np.ndarray, float | None]:
    """The values to plot and the first value they are measured from (None: as they are): a
    column whose spread is below RELATIVE_CHANGE_SHOWN of its size is plotted as its change."""
    finite = values[np.isfinite(values)]
    if len(finite) < 2:
        return values, None
    spread, size = float(np.ptp(finite)), float(np.max(np.abs(finite)))
    if spread > RELATIVE_CHANGE_SHOWN * size or size == 0:
        return values, None
    return values - finite[0], float(finite[0])


def _title(result) -> str:
    return result.origin or "lagdsl run"


def _unit_of(result, column: str) -> str | None:
    if column == "t":
        return "s" if result.units is not None else None
    return result.units[result.columns.index(column)] if result.units is not None else None


def _plot_column(axis, x: np.ndarray, result, column: str) -> None:
    values, first = _shown(np.asarray(result[column], dtype=float))
    unit = _unit_of(result, column)
    axis.plot(x, values, linewidth=1)
    axis.set_ylabel(labelled(column if first is None else f"Δ{column}", unit, LABEL_WIDTH))
    if first is not None:
        value = f"{first:.15g}" + (f" {unit}" if unit and unit != "?" else "")
        axis.set_title(f"Δ{column}: the change from {column}(t₀) = {value}", fontsize=8)
    axis.grid(True, alpha=0.3)
    _plain_ticks(axis)


def outputs_png(result) -> bytes:
    return _png(outputs_figure(result))


def trajectory_png(result, x: str, y: str) -> bytes:
    return _png(trajectory_figure(result, x, y))


def work_precision_png(report) -> bytes:
    return _png(work_precision_figure(report))


def outputs_figure(result):
    """The output columns against t, one panel per column (two columns of panels beyond three);
    the lowest panel of each column of panels carries the t axis."""
    figure, panels, lowest = _panel_grid(len(result.columns), 2.3, 0.8)
    for name, axis in zip(result.columns, panels):
        _plot_column(axis, result.t, result, name)
    for axis in lowest:
        axis.set_xlabel(labelled("t", _unit_of(result, "t")))
    figure.suptitle(_title(result), fontsize=10)
    figure.tight_layout()
    return figure


def _panel_grid(count: int, panel_height: float, margin: float):
    """A figure of `count` panels sharing x, one column of them up to three, two beyond: (figure,
    the panels in order, the lowest visible panel of each column, which shows the x tick labels,
    also above an empty cell)."""
    pyplot = _pyplot()
    across = 1 if max(1, count) <= 3 else 2
    down = math.ceil(max(1, count) / across)
    figure, axes = pyplot.subplots(down, across, figsize=(6.5 * across, panel_height * down + margin), squeeze=False,
                                   sharex=True)
    panels = [axes[index // across][index % across] for index in range(down * across)]
    for axis in panels[max(1, count):]:     # an empty run keeps one panel, for its t axis
        axis.set_visible(False)
    lowest = [axes[max(row for row in range(down) if axes[row][column].get_visible())][column]
              for column in range(across)]
    for axis in lowest:
        axis.tick_params(labelbottom=True)
    return figure, panels[:count], lowest


def check_columns(columns, xy: tuple[str, str], option: str = "--plot-xy") -> None:
    """Refuse a trajectory of columns the run does not write (before the run)."""
    for name in xy:
        if name != "t" and name not in columns:
            raise LagError(f"no column '{name}' to plot (columns: t, {', '.join(columns)})", Setting(option))


def trajectory_figure(result, x: str, y: str):
    """y against x (a trajectory), the start marked with a dot and the end with a square; equal
    scales on both axes when they have the same unit (an orbit looks round)."""
    check_columns(result.columns, (x, y), "xy")
    pyplot = _pyplot()
    figure, axis = pyplot.subplots(figsize=(6.5, 6))
    horizontal, vertical = np.asarray(result[x], dtype=float), np.asarray(result[y], dtype=float)
    axis.plot(horizontal, vertical, linewidth=1)
    axis.plot(horizontal[:1], vertical[:1], "o", color="black", markersize=4, label=f"t = {result.t[0]:.6g}")
    axis.plot(horizontal[-1:], vertical[-1:], "s", color="black", markersize=4, label=f"t = {result.t[-1]:.6g}")
    units = (_unit_of(result, x), _unit_of(result, y))
    axis.set_xlabel(labelled(x, units[0]))
    axis.set_ylabel(labelled(y, units[1]))
    if units[0] == units[1] and units[0] not in (None, "?"):
        axis.set_aspect("equal", adjustable="datalim")
    axis.grid(True, alpha=0.3)
    axis.legend(**LEGEND_BELOW, ncol=2)
    _plain_ticks(axis)
    axis.set_title(f"{_title(result)}: {y} against {x}", fontsize=10)
    figure.tight_layout()
    return figure


def work_precision_figure(report):
    """Left: error against integration time, log-log, one line per integrator and backend joined
    in the order of its tolerances (or steps), loosest first, so that noise in the times cannot
    fold a line back on itself; the reference's accuracy as a dotted line (points on it are at or
    below it, not measured). Right: |I(t) - I(t0)| of each conserved quantity for each method's
    tightest setting. The legends sit below the panels, off the data."""
    pyplot = _pyplot()
    panels = 2 if report.drifts else 1
    figure, axes = pyplot.subplots(1, panels, figsize=(6.5 * panels, 5), squeeze=False)
    diagram = axes[0][0]
    lines: dict[str, list] = {}
    for row in report.rows:
        if row.failure is None and row.seconds:
            lines.setdefault(row.setting.method, []).append(row)
    colors = _method_colors(sorted(lines))
    for method, rows in sorted(lines.items()):
        rows = sorted(rows, key=lambda r: -(r.setting.rtol if r.setting.rtol is not None else r.setting.step))
        peer = not registry.known(rows[0].setting.integrator)
        diagram.loglog([r.seconds for r in rows], [r.error for r in rows], marker="s" if peer else "o",
                       linestyle="--" if peer else "-", markersize=4, label=method, color=colors[method])
    diagram.axhline(report.reference.accuracy, color="grey", linestyle=":", linewidth=1,
                    label="reference accuracy")
    diagram.set_xlabel("integration time [s]")
    diagram.set_ylabel("largest abs error over rows and columns\n(each column in its unit)")
    diagram.set_title(f"{report.model}, scene {report.scene}: work against precision", fontsize=10)
    diagram.grid(True, which="major", alpha=0.3)
    diagram.legend(**LEGEND_BELOW, ncol=3)
    if report.drifts:
        _drift_panel(axes[0][1], report, colors)
    figure.tight_layout()
    return figure




def _method_colors(methods: list[str]) -> dict:
    """One colour per method, the same in both panels: tab10, or tab20 for more than ten methods."""
    import matplotlib
    palette = matplotlib.colormaps["tab10" if len(methods) <= 10 else "tab20"]
    return {method: palette(index % palette.N) for index, method in enumerate(methods)}


def _drift_panel(axis, report, colors: dict) -> None:
    """|I(t) - I(t0)| on a log scale (zeros, at the start, left out): a colour per method, as in the
    diagram beside it, a line style per quantity, which the legend names with its unit."""
    from matplotlib.lines import Line2D
    units = dict(report.invariant_units)
    styles: dict[str, str] = {}
    for drift in report.drifts:
        for name, values in drift.drifts:
            style = styles.setdefault(name, LINE_STYLES[len(styles) % len(LINE_STYLES)])
            magnitude = np.abs(values)
            shown = magnitude > 0
            axis.semilogy(drift.t[shown], magnitude[shown], linewidth=0.8,
                          color=colors.get(drift.setting.method, "black"), linestyle=style)
    axis.set_xlabel(labelled("t", "s" if units else None))
    axis.set_ylabel("|I(t) − I(t₀)|, in the unit of I" if units else "|I(t) − I(t₀)|")
    axis.set_title("drift of the conserved quantities, tightest setting of each method\n"
                   "(colours: the methods at the left)", fontsize=10)
    axis.grid(True, alpha=0.3)
    handles = [Line2D([], [], color="black", linewidth=0.8, linestyle=style, label=labelled(name, units.get(name)))
               for name, style in styles.items()]
    axis.legend(handles=handles, **LEGEND_BELOW, ncol=2)


def mode_shapes_png(modes, title: str, count: int = 10) -> bytes:
    """The shapes of the `count` lowest modes (linear/modes.py), one panel each: every
    coordinate's amplitude (the real part of the shape scaled to a largest entry of 1; the
    modulus dashed where the shape is complex), the frequency and the verdict above it."""
    shown = modes.modes[:max(1, count)]
    figure, panels, lowest = _panel_grid(len(shown), 1.9, 0.9)
    positions = np.arange(len(modes.coordinates))
    marker = "o" if len(positions) <= 40 else None
    for number, (mode, axis) in enumerate(zip(shown, panels), start=1):
        axis.axhline(0, color="0.6", linewidth=0.6)
        axis.plot(positions, mode.shape.real, marker=marker, linewidth=1)
        if np.any(np.abs(mode.shape.imag) > 1e-12):
            axis.plot(positions, np.abs(mode.shape), linestyle="--", linewidth=0.8, color="0.4")
        axis.set_ylim(-1.1, 1.1)
        axis.set_title(f"mode {number}: {mode.omega:.6g} rad/s, {mode.verdict}", fontsize=9)
        axis.grid(True, alpha=0.3)
    for axis in lowest:
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


def lyapunov_png(spectrum) -> bytes:
    """`lagc lyapunov --plot`: each exponent's running estimate against t (sensitivity/lyapunov.py)."""
    pyplot = _pyplot()
    figure, axes = pyplot.subplots(figsize=(8, 5))
    for i in range(spectrum.running.shape[1]):
        axes.plot(spectrum.times, spectrum.running[:, i], label=f"λ{i + 1} = {spectrum.exponents[i]:.4g}")
    axes.axhline(0.0, color="black", linewidth=0.5)
    axes.set_xlabel("t [s]")
    axes.set_ylabel("running estimate [1/s]")
    axes.set_title(f"Lyapunov exponents of {spectrum.title}")
    axes.legend()
    figure.tight_layout()
    return _png(figure)
