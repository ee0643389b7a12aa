"""Figures: titled with the model and scene, every axis with its unit, no additive tick offsets,
no lost t axis beside an empty panel, trajectories, and the work-precision diagram's lines in
tolerance order with its legends off the data."""
from __future__ import annotations

import numpy as np
import pytest

from lagdsl import plots
from lagdsl.bench import BenchReport, BenchRow, Drift, Setting
from lagdsl.cli import main
from lagdsl.errors import LagError
from lagdsl.reference import Reference
from lagdsl.run.output import Result, RunSummary
from tests.conftest import MODELS

T = np.linspace(0, 2, 201)
SUMMARY = RunSummary("c", "dop853", (), 0.0, (), (), None, None)


def result(columns: dict, units: tuple[str, ...] | None) -> Result:
    return Result(T, tuple(columns), np.column_stack(list(columns.values())), SUMMARY, units, "Orbit, scene circle")


CIRCLE = {"x": np.cos(T), "y": np.sin(T), "theta": 30 + 20 * T, "energy": 1.87825088e-13 + 1e-24 * np.sin(T),
          "speed": np.ones_like(T)}
CIRCLE_UNITS = ("m", "m", "deg", "J", "m/s")


@pytest.fixture
def drawn():
    figures = []

    def draw(figure):
        figures.append(figure)
        figure.canvas.draw()
        return figure

    yield draw
    for figure in figures:
        plots.close(figure)


def test_outputs_are_titled_by_model_and_scene_with_a_unit_on_every_axis(drawn):
    figure = drawn(plots.outputs_figure(result(CIRCLE, CIRCLE_UNITS)))
    assert figure._suptitle.get_text() == "Orbit, scene circle"
    shown = [axis for axis in figure.axes if axis.get_visible()]
    assert [axis.get_ylabel() for axis in shown] == ["x [m]", "y [m]", "theta [deg]", "Δenergy [J]", "Δspeed [m/s]"]
    assert "1.87825088e-13 J" in shown[3].get_title()         # the value the change is measured from


def test_no_tick_label_is_shifted_by_an_offset(drawn):
    figure = drawn(plots.outputs_figure(result(CIRCLE, CIRCLE_UNITS)))
    for axis in figure.axes:
        if axis.get_visible():
            assert "+" not in axis.yaxis.get_major_formatter().get_offset()
            assert len({label.get_text() for label in axis.get_yticklabels()}) > 1     # ticks tell apart


def test_the_panel_above_an_empty_one_keeps_the_t_axis(drawn):
    figure = drawn(plots.outputs_figure(result(CIRCLE, CIRCLE_UNITS)))     # 5 panels in a 3 x 2 grid
    grid = np.array(figure.axes).reshape(3, 2)
    assert not grid[2][1].get_visible()
    for axis in (grid[1][1], grid[2][0]):
        assert axis.get_xlabel() == "t [s]"
        assert any(label.get_visible() and label.get_text() for label in axis.get_xticklabels())


def test_a_model_without_units_has_bare_labels(drawn):
    figure = drawn(plots.outputs_figure(result({"x": np.cos(T)}, None)))
    assert figure.axes[0].get_ylabel() == "x" and figure.axes[0].get_xlabel() == "t"


def test_trajectory_y_against_x_with_equal_scales(drawn, tmp_path):
    figure = drawn(plots.trajectory_figure(result(CIRCLE, CIRCLE_UNITS), "x", "y"))
    axis, = figure.axes
    assert (axis.get_xlabel(), axis.get_ylabel()) == ("x [m]", "y [m]")
    assert axis.get_title() == "Orbit, scene circle: y against x" and axis.get_aspect() == 1.0
    result(CIRCLE, CIRCLE_UNITS).plot(tmp_path / "orbit.png", xy=("x", "y"))
    assert (tmp_path / "orbit.png").read_bytes().startswith(b"\x89PNG")
    with pytest.raises(LagError, match="no column 'z' to plot"):
        result(CIRCLE, CIRCLE_UNITS).plot(tmp_path / "none.png", xy=("x", "z"))


def bench_report() -> BenchReport:
    """dop853's ladder with noisy times, listed out of order; a drift of two quantities."""
    reference = Reference(T, ("x",), np.zeros((len(T), 1)), 1e-15, "dop853", "float128", 1e-20, 1e-22, 1.0, True)
    rows = tuple(BenchRow(Setting("dop853", "c", rtol=rtol, atol=rtol / 100), seconds, 10, 10, 0, error, 1e-15)
                 for rtol, seconds, error in ((1e-6, 2e-4, 1e-7), (1e-3, 3e-4, 1e-4), (1e-9, 1e-4, 1e-10)))
    drift = Drift(rows[2].setting, T, (("energy", 1e-12 * T), ("momentum(theta)", 1e-13 * T)))
    return BenchReport("Kepler", "ellipse", reference, rows, (), (drift,),
                       (("energy", "J"), ("momentum(theta)", "kg*m^2/s")))


def test_work_precision_lines_follow_the_tolerances_and_legends_sit_below(drawn):
    figure = drawn(plots.work_precision_figure(bench_report()))
    diagram, drift = figure.axes
    line = next(line for line in diagram.get_lines() if line.get_label() == "dop853 (c)")
    assert list(line.get_ydata()) == [1e-4, 1e-7, 1e-10]            # loosest first, whatever the times
    for axis in (diagram, drift):
        legend = axis.get_legend()
        inside = axis.get_window_extent()
        assert legend.get_window_extent().y1 < inside.y0             # below the axes, off the data
    assert drift.get_xlabel() == "t [s]" and "unit of I" in drift.get_ylabel()
    assert [text.get_text() for text in drift.get_legend().get_texts()] == ["energy [J]",
                                                                           "momentum(theta) [kg*m^2/s]"]


def test_lagc_run_plots_a_trajectory(tmp_path, capsys):
    model = str(MODELS / "charged_particle.lag")
    picture = tmp_path / "helix.png"
    assert main(["run", model, "--stop", "1", "-o", str(tmp_path / "out.csv"), "--plot", str(picture),
                 "--plot-xy", "x,y"]) == 0
    assert picture.read_bytes().startswith(b"\x89PNG")
    capsys.readouterr()
    assert main(["run", model, "--plot-xy", "x,y"]) == 1
    assert capsys.readouterr().err == ("lagc: error: --plot-xy: needs --plot FILE.png, the figure to draw the "
                                       "trajectory in\n")
    assert main(["run", model, "--plot", str(picture), "--plot-xy", "x,w"]) == 1
    assert "lagc: error: --plot-xy: no column 'w' to plot (columns: t, x, y, z" in capsys.readouterr().err
