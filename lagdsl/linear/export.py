"""Linear models and modes as files and text: JSON, NumPy .npz, MATLAB .mat, the modes CSV and
the table `lagc modes` prints. Every file is written whole or not at all (run/files.write_output)."""
from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from ..errors import LagError, Setting
from ..run.files import write_output
from ..run.tables import csv_text
from .model import LinearModel
from .modes import Modes, rows

MATRICES = ("M", "D", "G", "K", "N", "Bq", "A", "B", "C", "Dm", "basis")
FORMATS = (".json", ".npz", ".mat")


def check_format(path: str) -> str:
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise LagError(f"cannot tell the format of '{path}': name it .json, .npz or .mat", Setting("-o"))
    return suffix


def write_linear(path: str, linear: LinearModel, model_name: str, scene: str) -> None:
    """The matrices with the names of the coordinates, states, inputs and outputs, in the format
    the file's suffix names (check_format)."""
    names = {"model": model_name, "scene": scene, "coordinates": list(linear.coordinates),
             "eliminated": list(linear.eliminated), "all_coordinates": list(linear.all_coordinates),
             "states": list(linear.states), "inputs": list(linear.inputs), "outputs": list(linear.outputs)}
    numbers = {"point": linear.point, "parameters": linear.parameters, "time": linear.time,
               "output_values": linear.output_values.tolist()}
    matrices = {name: np.asarray(getattr(linear, name), dtype=float) for name in MATRICES
                if getattr(linear, name) is not None}        # first-order only: no M, D, G, K, N, Bq
    suffix = check_format(path)
    if suffix == ".json":
        document = {**names, **numbers, "matrices": {k: v.tolist() for k, v in matrices.items()}}
        write_output(path, json.dumps(document, indent=1) + "\n")
        return
    # names as cell arrays in MATLAB, as string arrays in .npz (readable without pickle)
    text = object if suffix == ".mat" else str
    arrays = {**{k: v if isinstance(v, str) else np.array(v, dtype=text) for k, v in names.items()},
              "point_names": np.array(list(linear.point), dtype=text), "point": np.array(list(linear.point.values())),
              "parameter_names": np.array(list(linear.parameters), dtype=text),
              "parameters": np.array(list(linear.parameters.values())), "time": np.array(linear.time),
              "output_values": linear.output_values, **matrices}
    buffer = io.BytesIO()
    if suffix == ".npz":
        np.savez(buffer, **arrays)
    else:
        import scipy.io
        scipy.io.savemat(buffer, arrays, oned_as="column")
    write_output(path, buffer.getvalue())


def modes_csv(modes: Modes) -> str:
    header, columns = rows(modes)
    return csv_text(header, columns)


def modes_text(modes: Modes, linear: LinearModel, title: str) -> str:
    """The table `lagc modes` prints: one row per mode, then the verdict and how it was reached."""
    lines = [f"modes of {title} about {_point_text(linear.point)}",
             f"coordinates: {_names_text(linear.coordinates)}"
             + (f" ({_names_text(linear.eliminated)} eliminated by the constraints)" if linear.eliminated else ""),
             *_velocities_line(linear),
             f"{'mode':>5} {'omega [rad/s]':>16} {'frequency [Hz]':>16} {'damping ratio':>14} "
             f"{'real s [1/s]':>14} {'imag s [rad/s]':>15}  verdict"]
    for index, mode in enumerate(modes.modes, 1):
        lines.append(f"{index:>5} {mode.omega:>16.10g} {mode.frequency_hz:>16.10g} {mode.damping_ratio + 0.0:>14.6g} "
                     f"{mode.s.real:>14.6g} {mode.s.imag:>15.10g}  {mode.verdict}")
    largest = max((m.omega for m in modes.modes), default=0.0)
    lines.append(f"verdict: {modes.verdict} (a mode is unstable when Re s > {modes.tolerance:g} max(|s|max, 1/s) "
                 f"= {modes.tolerance * max(largest, 1.0):.3g} 1/s); eigensolver: {modes.method}")
    return "\n".join(lines) + "\n"


def _point_text(point: dict[str, float], shown: int = 8) -> str:
    """The nonzero entries of the point (the first `shown` of them); the rest are zero."""
    nonzero = [f"{name} = {value:.6g}" for name, value in point.items() if value != 0]
    if not nonzero:
        return "the state where every coordinate and velocity is 0"
    more = f" and {len(nonzero) - shown} more" if len(nonzero) > shown else ""
    rest = ", every other coordinate and velocity 0" if len(nonzero) < len(point) else ""
    return ", ".join(nonzero[:shown]) + more + rest


def _names_text(names, shown: int = 12) -> str:
    return ", ".join(names) if len(names) <= shown else f"{names[0]}, {names[1]}, ..., {names[-1]} ({len(names)})"


def _velocities_line(linear: LinearModel) -> list[str]:
    """For a first-order model on the constraints' tangent space: the velocities it eliminated."""
    velocities = [f"{q}.velocity" for q in linear.all_coordinates]
    gone = [v for v in velocities if v not in linear.states]
    return [f"velocities eliminated by the constraints: {_names_text(gone)}"] if linear.M is None and gone else []
