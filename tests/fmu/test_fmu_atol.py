"""The atol of each component of the state in a co-simulation FMU: fixed parameters
integrator.atol.x and integrator.atol.'der(x)', in the unit of the state variable (SI, as every
value of the FMU), starting at the scene's; 0 means integrator.atol."""
from __future__ import annotations

import io
import math
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

from lagdsl.api import Model
from lagdsl.fmu import build_fmu
from lagdsl.source import SourceFile
from tests.run.test_atol_units import CART


@pytest.fixture(scope="module")
def cart():
    return Model(SourceFile("cart.lag", CART))


def described(fmu: bytes) -> dict[str, dict]:
    """The variables of modelDescription.xml by name: their attributes and their Real's."""
    root = ET.fromstring(zipfile.ZipFile(io.BytesIO(fmu)).read("modelDescription.xml"))
    return {v.get("name"): {**v.attrib, **(v.find("Real").attrib if v.find("Real") is not None else {})}
            for v in root.iter("ScalarVariable")}


def test_each_component_has_its_atol_in_the_state_unit_from_the_scene(cart):
    variables = described(build_fmu(cart, "named", 2, ("cs",)))
    x, vx, theta, vtheta = (variables[f"integrator.atol.{name}"] for name in ("x", "'der(x)'", "theta", "'der(theta)'"))
    assert all(v["causality"] == "parameter" and v["variability"] == "fixed" for v in (x, vx, theta, vtheta))
    assert (x["unit"], vx["unit"], theta["unit"], vtheta["unit"]) == ("m", "m/s", "rad", "rad/s")
    # atol(x) = 0.0005 [mm] in m; der(x) named alone: atol(x) / (stop - start); theta not named: 0
    assert float(x["start"]) == 5e-7 and float(vx["start"]) == 5e-7 / 2 and float(theta["start"]) == 0
    assert float(vtheta["start"]) == pytest.approx(0.5 * math.pi / 180, rel=1e-15)
    assert not any(name.startswith("integrator.atol.") for name in described(build_fmu(cart, "named", 2, ("me",))))


@pytest.mark.parametrize("version", [2, 3])
def test_co_simulation_honours_the_scenes_atol_and_the_importers(tmp_path, cart, version):
    fmpy = pytest.importorskip("fmpy")
    run = cart.simulate("named")
    for scene, start_values in (("named", {}), ("plain", {"integrator.atol.x": 5e-7, "integrator.atol.'der(x)'": 2.5e-7,
                                                         "integrator.atol.'der(theta)'": 0.5 * math.pi / 180})):
        path = tmp_path / f"{scene}.fmu"
        path.write_bytes(build_fmu(cart, scene, version, ("cs",)))
        result = fmpy.simulate_fmu(str(path), fmi_type="CoSimulation", output_interval=0.1, output=["x", "theta"],
                                   start_values=start_values)
        assert np.array_equal(result["time"], run.t)
        for column in ("x", "theta"):
            assert np.array_equal(result[column], run[column]), (scene, column)
    scalar = fmpy.simulate_fmu(str(tmp_path / "plain.fmu"), fmi_type="CoSimulation", output_interval=0.1,
                               output=["x"])
    assert not np.array_equal(scalar["x"], run["x"])
