"""modelDescription.xml of an FMU: the variables with their attributes, units and derivatives,
and the units' definitions in SI base units (FMI 2.0 and 3.0)."""
from __future__ import annotations

import io
import xml.etree.ElementTree as ET
import zipfile

from lagdsl.fmu import build_fmu
from tests.fmu.fmu_files import load


def description(version: int, kinds: tuple[str, ...] | None = None) -> ET.Element:
    with zipfile.ZipFile(io.BytesIO(build_fmu(load("double_pendulum"), version=version, kinds=kinds))) as archive:
        return ET.fromstring(archive.read("modelDescription.xml"))


def variables(root: ET.Element) -> dict[str, dict[str, str]]:
    """name -> its attributes, with those of FMI 2.0's type element (Real, Integer) merged in."""
    found = {}
    for variable in root.find("ModelVariables"):
        attributes = dict(variable.attrib)
        for typed in variable:
            attributes.update(typed.attrib)
        found[variable.get("name")] = attributes
    return found


def test_parameters_states_and_outputs_in_fmi2():
    root = description(2)
    listed = variables(root)
    assert listed["m2"] | {"valueReference": ""} == {
        "name": "m2", "valueReference": "", "description": "mass of the lower bob", "causality": "parameter",
        "variability": "tunable", "initial": "exact", "start": "1.0", "unit": "kg"}
    order = list(listed)
    assert listed["der(theta1)"]["derivative"] == str(order.index("theta1") + 1)
    assert listed["der(theta1,2)"]["derivative"] == str(order.index("der(theta1)") + 1)
    assert listed["der(theta1)"]["unit"] == "rad/s" and listed["der(theta1,2)"]["unit"] == "rad/s^2"
    assert listed["energy"]["causality"] == "output" and listed["energy"]["unit"] == "J"
    assert listed["momentum.theta2"]["unit"] == "kg*m^2/s"
    assert listed["integrator.rtol"]["variability"] == "fixed" and listed["integrator.rtol"]["start"] == "1e-10"
    units = {unit.get("name"): unit.find("BaseUnit").attrib for unit in root.iter("Unit")}
    assert units["J"] == {"kg": "1", "m": "2", "s": "-2"} and units["rad/s"] == {"s": "-1", "rad": "1"}
    derivatives = root.findall("ModelStructure/Derivatives/Unknown")
    assert [order[int(unknown.get("index")) - 1] for unknown in derivatives] == [
        "der(theta1)", "der(theta2)", "der(theta1,2)", "der(theta2,2)"]


def test_co_simulation_only_has_no_accelerations_and_fmi3_has_time():
    assert "der(theta1,2)" not in variables(description(2, ("cs",)))
    listed = variables(description(3))
    assert listed["time"]["causality"] == "independent"
    assert listed["der(theta1,2)"]["derivative"] == listed["der(theta1)"]["valueReference"]
