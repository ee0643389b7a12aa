"""An FMU's variables -> modelDescription.xml (FMI 2.0 or 3.0) and buildDescription.xml (FMI 3.0).

The XML is built with ElementTree (which escapes the model's text) in a fixed order, with no
date, so that the same export gives the same bytes. The variables' attributes come from
codegen/fmu.py; the units' definitions from codegen/fmu_units.py.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET

from .. import __version__
from ..scene import ScenePlan
from .fmu import LOG_CATEGORIES, FmuVariable
from .fmu_units import UNKNOWN, unit_definition

BASE_UNITS = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")     # the order of FMI's BaseUnit attributes


def model_description(plan: ScenePlan, variables: tuple[FmuVariable, ...], kinds: tuple[str, ...], version: int,
                      identifier: str, token: str) -> bytes:
    """modelDescription.xml of an export of `plan` with `variables` (codegen.fmu.fmu_variables)."""
    model, me = plan.model, "me" in kinds
    root = ET.Element("fmiModelDescription", _attributes(
        fmiVersion=f"{version}.0", modelName=model.name, **{"guid" if version == 2 else "instantiationToken": token},
        description=model.description, generationTool=f"lagdsl {__version__}", variableNamingConvention="structured",
        numberOfEventIndicators=str(int(me and plan.stop is not None)) if version == 2 else None))
    interface = {"me": ("ModelExchange", _model_exchange(version)),
                 "cs": ("CoSimulation", _co_simulation(version, plan.stop is not None))}
    for kind in ("me", "cs"):
        if kind in kinds:
            element = ET.SubElement(root, interface[kind][0], modelIdentifier=identifier, **interface[kind][1])
            if version == 2:
                ET.SubElement(ET.SubElement(element, "SourceFiles"), "File", name=f"{identifier}.c")
    _unit_definitions(root, variables)
    categories = ET.SubElement(root, "LogCategories")
    for name, description in LOG_CATEGORIES:
        ET.SubElement(categories, "Category", name=name, description=description)
    options = dict(plan.integrator.options)
    ET.SubElement(root, "DefaultExperiment", _attributes(
        startTime=_number(plan.time.start), stopTime=_number(plan.time.stop),
        tolerance=_number(options["rtol"]) if "rtol" in options else None, stepSize=_number(plan.time.interval)))
    listed, positions = ET.SubElement(root, "ModelVariables"), {v.name: i for i, v in enumerate(variables)}
    for variable in variables:
        _variable(listed, variable, variables, positions, version)
    _model_structure(root, variables, positions, version)
    return _text(root)


def build_description(identifier: str) -> bytes:
    """buildDescription.xml of FMI 3.0: one C99 file, and libm."""
    root = ET.Element("fmiBuildDescription", fmiVersion="3.0")
    configuration = ET.SubElement(root, "BuildConfiguration", modelIdentifier=identifier)
    files = ET.SubElement(configuration, "SourceFileSet", language="C99")
    ET.SubElement(files, "SourceFile", name=f"{identifier}.c")
    ET.SubElement(configuration, "Library", name="m", external="true", description="the C math library")
    return _text(root)


def _model_exchange(version: int) -> dict[str, str]:
    if version == 2:
        return {"completedIntegratorStepNotNeeded": "true", "canNotUseMemoryManagementFunctions": "true"}
    return {"needsCompletedIntegratorStep": "false"}


def _co_simulation(version: int, stops: bool) -> dict[str, str]:
    """Steps of any size; a stop condition may end a step early (FMI 3's early return)."""
    if version == 2:
        return {"canHandleVariableCommunicationStepSize": "true", "canNotUseMemoryManagementFunctions": "true"}
    return {"canHandleVariableCommunicationStepSize": "true", "mightReturnEarlyFromDoStep": str(stops).lower()}


def _unit_definitions(root: ET.Element, variables: tuple[FmuVariable, ...]) -> None:
    names = sorted({variable.unit for variable in variables if variable.unit != UNKNOWN})
    if not names:
        return
    units = ET.SubElement(root, "UnitDefinitions")
    for name in names:
        definition = unit_definition(name)
        unit = ET.SubElement(units, "Unit", name=name)
        if definition.exponents is not None:
            exponents = {base: str(definition.exponents[base]) for base in BASE_UNITS if base in definition.exponents}
            factor = {} if definition.factor == 1 else {"factor": _number(definition.factor)}
            ET.SubElement(unit, "BaseUnit", {**exponents, **factor})


def _variable(parent: ET.Element, variable: FmuVariable, variables: tuple[FmuVariable, ...],
              positions: dict[str, int], version: int) -> None:
    """A ScalarVariable (FMI 2) or a Float64 or Int32 (FMI 3). A derivative names its state by
    its index from 1 (FMI 2) or its value reference (FMI 3); `positions`: each variable's index
    in `variables` by its name."""
    state = variables[positions[variable.derivative_of]] if variable.derivative_of in positions else None
    common = _attributes(name=variable.name, valueReference=str(variable.reference), description=variable.description,
                         causality=variable.causality, variability=variable.variability, initial=variable.initial)
    typed = _attributes(start=None if variable.start is None else
                        str(int(variable.start)) if variable.integer else _number(variable.start),
                        unit=None if variable.unit == UNKNOWN else variable.unit,
                        derivative=None if state is None else
                        str(positions[state.name] + 1) if version == 2 else str(state.reference))
    if version == 2:
        scalar = ET.SubElement(parent, "ScalarVariable", common)
        ET.SubElement(scalar, "Integer" if variable.integer else "Real", typed)
    else:
        ET.SubElement(parent, "Int32" if variable.integer else "Float64", {**common, **typed})


def _model_structure(root: ET.Element, variables: tuple[FmuVariable, ...], positions: dict[str, int],
                     version: int) -> None:
    """Outputs; derivatives in the order of the states (y = q, q'); the initial unknowns (what is
    calculated among the outputs, states and derivatives); FMI 3's event indicator."""
    structure = ET.SubElement(root, "ModelStructure")
    derivatives = sorted((v for v in variables if v.derivative_of is not None), key=lambda v: positions[v.derivative_of])
    derived = {v.name for v in derivatives} | {v.derivative_of for v in derivatives}
    groups = (("Outputs", "Output", [v for v in variables if v.causality == "output"]),
              ("Derivatives", "ContinuousStateDerivative", derivatives),
              ("InitialUnknowns", "InitialUnknown",
               [v for v in variables if v.initial == "calculated" and (v.causality == "output" or v.name in derived)]),
              (None, "EventIndicator", [v for v in variables if v.kind == "indicator"]))
    for group, element, members in groups:
        if version == 2 and group is not None and members:
            parent = ET.SubElement(structure, group)
            for member in members:
                ET.SubElement(parent, "Unknown", index=str(positions[member.name] + 1))
        elif version == 3:
            for member in members:
                ET.SubElement(structure, element, valueReference=str(member.reference))


def _attributes(**values: str | None) -> dict[str, str]:
    """The attributes given (None: left out), in the order given."""
    return {name: value for name, value in values.items() if value is not None}


def _number(value: float) -> str:
    return repr(float(value))


def _text(root: ET.Element) -> bytes:
    ET.indent(root, space="  ")
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8") + b"\n"
