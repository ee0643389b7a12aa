"""FMUs of `lagc --emit fmu` in a client nobody here wrote: FMPy validates them and simulates them,
in co-simulation (the scene's integrator inside the FMU) and in model exchange (FMPy's CVode
integrating the FMU's derivatives), against `lagc run` of the same scene."""
from __future__ import annotations

import hashlib
import io
import itertools
import warnings
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

import lagdsl
from lagdsl.errors import LagWarning
from lagdsl.fmu import build_fmu
from tests.conftest import MODELS, model_file
from tests.fmu.fmu_files import fmu_file, load

fmpy = pytest.importorskip("fmpy")
from fmpy.validation import validate_fmu  # noqa: E402  (after the skip when FMPy is absent)

PROJECTILE = """model Projectile "a thrown point mass; the flight ends where it comes down"
  parameter m = 1 [kg];
  parameter g = 9.81 [m/s^2];
  coordinate x(velocity = 3) [m];
  coordinate y(velocity = 4) [m];
  T = m*(der(x)^2 + der(y)^2)/2;
  U = m*g*y;
  scene flight
    time(stop = 2, interval = 0.1);
    integrator dopri5(rtol = 1e-10, atol = 1e-12);
    stop when y < 0;
    output y, der(y);
  end flight;
end Projectile;
"""


VERSIONS = pytest.mark.parametrize("version", [2, 3])


@pytest.fixture(scope="module", params=[2, 3], ids=["fmi2", "fmi3"])
def double_pendulum(tmp_path_factory, request):
    return str(fmu_file(tmp_path_factory.mktemp("fmu"), "double_pendulum", version=request.param))


@VERSIONS
@pytest.mark.parametrize("name, scene", [("double_pendulum", None), ("rolling_penny", None), ("pendulum", "symplectic"),
                                         ("bead_on_hoop", None),
                                         pytest.param("fpu_chain", "implicit", marks=pytest.mark.slow)])
def test_fmpy_finds_no_problem(tmp_path, name, scene, version, names_parsed_once):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LagWarning)        # a symplectic scene: co-simulation only
        assert validate_fmu(str(fmu_file(tmp_path, name, scene, version=version))) == []


NAME_VERDICTS = "lagdsl/fmpy-name-verdicts"      # the key of the verdicts kept in pytest's cache


@pytest.fixture
def names_parsed_once(monkeypatch, request):
    """FMPy checks each variable's structured name with a lark Earley parser, built and run afresh
    for every FMU (50 ms to build, 8 ms a name: 6 s for each of the FPU chain's three scenes, 34 s
    over the library in one FMI version), and asks only whether the parse raises. The names recur in
    every scene of a model, in both versions and in every run: here the parser is built when a name
    is new, each distinct name is parsed by the same grammar once, and its verdict (passed, or the error's text, which FMPy reports) kept in pytest's
    cache, as conftest's `compiled` keeps a compile: the same lark, grammar and text give the same
    verdict, in this run and the next (a new name, grammar or lark is parsed)."""
    import lark
    original = lark.Lark
    store = getattr(request.config, "cache", None)          # none with -p no:cacheprovider
    verdicts = store.get(NAME_VERDICTS, {}) if store is not None else {}

    built = {}                          # FMPy's name parser by grammar, built on the first name not kept

    class ParsedOnce(lark.Lark):
        def __init__(self, grammar, **options):
            self.name_grammar = grammar if options == {"start": "name"} else None      # FMPy's alone
            if self.name_grammar is None:
                super().__init__(grammar, **options)

        def parse(self, text, *args, **kwargs):
            if self.name_grammar is None or args or kwargs:
                return super().parse(text, *args, **kwargs)
            key = hashlib.sha256(f"{lark.__version__}\0{self.name_grammar}\0{text}".encode()).hexdigest()[:32]
            if key not in verdicts:
                if self.name_grammar not in built:
                    built[self.name_grammar] = original(self.name_grammar, start="name")
                try:
                    built[self.name_grammar].parse(text)
                    verdicts[key] = None
                except lark.exceptions.LarkError as error:
                    verdicts[key] = str(error)
            if verdicts[key] is not None:
                raise lark.exceptions.LarkError(verdicts[key])

    monkeypatch.setattr(lark, "Lark", ParsedOnce)
    yield
    if store is not None:
        store.set(NAME_VERDICTS, verdicts)


@pytest.mark.slow
def test_fmpy_finds_no_problem_in_any_library_model(tmp_path, names_parsed_once):
    """Both FMI versions in one test, so that the second reads the names' verdicts of the first."""
    problems = {}
    for path in sorted(MODELS.glob("*.lag")):
        for scene, version in itertools.product(load(path.stem).ir.scenes, (2, 3)):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", LagWarning)
                found = validate_fmu(str(fmu_file(tmp_path, path.stem, scene.name, version=version)))
            if found:
                problems[f"{path.stem}.{scene.name} fmi{version}"] = found
    assert problems == {}


def test_co_simulation_with_a_start_value_is_lagc_run(double_pendulum):
    """m2 changed through the start values: the rows of the FMU's steps are those of `lagc run
    --set m2=2` (the same integrator stepping over the same communication points)."""
    run = load("double_pendulum").simulate(m2=2.0)
    result = fmpy.simulate_fmu(double_pendulum, fmi_type="CoSimulation", start_values={"m2": 2.0},
                               output_interval=0.01, output=["theta1", "theta2", "energy"])
    assert np.array_equal(result["time"], run.t)
    for column in ("theta1", "theta2", "energy"):
        np.testing.assert_allclose(result[column], run[column], rtol=0, atol=1e-9)


def test_model_exchange_under_cvode_agrees_to_its_tolerance(double_pendulum):
    """FMPy's CVode integrates the FMU's derivatives (q', q'' from the mass matrix solve); over two
    seconds of the chaotic pendulum its global error stays within a few hundred times its rtol."""
    run = load("double_pendulum").simulate(m2=2.0, stop=2)
    result = fmpy.simulate_fmu(double_pendulum, fmi_type="ModelExchange", solver="CVode", relative_tolerance=1e-10,
                               stop_time=2, output_interval=0.01, start_values={"m2": 2.0},
                               output=["theta1", "theta2"])
    assert np.array_equal(result["time"], run.t)
    for column in ("theta1", "theta2"):
        np.testing.assert_allclose(result[column], run[column], rtol=0, atol=1e-7)


@VERSIONS
def test_rolling_penny_keeps_its_constraints_in_co_simulation(tmp_path, version):
    """The nonholonomic rolling conditions: the FMU projects its rows as `lagc run` does, so the
    residuals stay at the run's level (round-off)."""
    run = load("rolling_penny").simulate()
    result = fmpy.simulate_fmu(str(fmu_file(tmp_path, "rolling_penny", kinds=("cs",), version=version)), output_interval=0.01)
    for constraint in ("roll_x", "roll_y"):
        residual = np.max(np.abs(result[f"residual.{constraint}"]))
        assert residual <= max(np.max(np.abs(run[f"residual({constraint})"])), 1e-15)
        np.testing.assert_allclose(result[f"multiplier.{constraint}"], run[f"multiplier({constraint})"], atol=1e-12)


@VERSIONS
def test_stop_condition_ends_the_co_simulation_where_lagc_run_ends(tmp_path, version):
    model = lagdsl.load(model_file(PROJECTILE, "projectile"))      # its library found again in the next run
    run = model.simulate()
    fmu = tmp_path / "projectile.fmu"
    fmu.write_bytes(build_fmu(model, version=version))
    early = {"early_return_allowed": True} if version == 3 else {}     # FMI 3: the step ends at the event
    result = fmpy.simulate_fmu(str(fmu), fmi_type="CoSimulation", output_interval=0.1, **early)
    assert result["time"][-1] == pytest.approx(run.t[-1], abs=1e-12) and run.t[-1] < 2
    np.testing.assert_allclose(result["y"], run["y"], atol=1e-12)


@VERSIONS
def test_a_stop_on_a_multiplier_ends_the_co_simulation_where_lagc_run_ends(tmp_path, version):
    """The ladder leaves the wall where the wall's multiplier turns negative (models/ladder.lag)."""
    model = load("ladder")
    run = model.simulate()
    fmu = tmp_path / "ladder.fmu"
    fmu.write_bytes(build_fmu(model, version=version))
    early = {"early_return_allowed": True} if version == 3 else {}
    result = fmpy.simulate_fmu(str(fmu), fmi_type="CoSimulation", output_interval=0.01, **early)
    assert result["time"][-1] == pytest.approx(run.t[-1], abs=1e-12) and run.t[-1] < 1
    np.testing.assert_allclose(result["y"], run["y"], atol=1e-12)


def test_an_export_is_the_same_bytes_and_keeps_its_value_references(tmp_path):
    model = load("double_pendulum")
    assert build_fmu(model) == build_fmu(model)

    def references(fmu: bytes) -> dict[str, str]:
        with zipfile.ZipFile(io.BytesIO(fmu)) as archive:
            root = ET.fromstring(archive.read("modelDescription.xml"))
        return {v.get("name"): v.get("valueReference") for v in root.find("ModelVariables")}

    both = references(build_fmu(model))
    for other in (references(build_fmu(model, kinds=("cs",))), references(build_fmu(model, version=3))):
        shared = both.keys() & other.keys()
        assert {"m2", "theta1", "der(theta1)", "energy"} <= shared
        assert all(both[name] == other[name] for name in shared)
