"""The C sweep in SIMD lanes (integrators/c/lanes.c; dop853_lanes.c with codegen/c_lanes.py,
taylor_lanes.c with codegen/c_taylor_lanes.py): with dop853 and taylor, a member's rows, status and
counters equal its simulate() bit for bit (taylor with either norm), whichever lane ran it and whatever ran beside it; failing
members end alone; 10^5 members take the result's memory plus a constant."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from lagdsl.codegen.c_lanes import lane_groups
from lagdsl.codegen.kernel import lower_to_kernel
from lagdsl.errors import SimulationError
from lagdsl.settings import Overrides
from tests.conftest import MODELS, library_model

# (model, scene, the ranges of the values drawn for each member, stop)
LANE_MODELS = {
    "double_pendulum": ("chaos", {"theta1.start": (-3, 3), "theta2.start": (-3, 3), "m2": (0.5, 2)}, 3.0),
    "pendulum": ("swing", {"theta.start": (-3, 3), "l": (0.5, 2)}, 3.0),          # M constant: factored once
    "triple_pendulum": ("chaos", {"theta1.start": (-2, 2), "theta3.start": (-2, 2)}, 2.0),
    "henon_heiles": ("mixed", {"x.start": (-0.1, 0.1)}, 5.0),
    "kepler": ("ellipse", {"r.velocity": (-0.2, 0.2), "m": (0.5, 2)}, 5.0),
    "elastic_pendulum": ("soft", {"phi.start": (-1, 1), "k": (5, 50)}, 3.0),
    "heavy_top": ("nutation", {"theta.start": (0.3, 1.2)}, 2.0),
    "cart_pole": ("fall", {"theta.start": (-1, 1), "m": (0.1, 1)}, 2.0),
    "damped_driven_pendulum": ("driven", {"theta.start": (-1, 1)}, 3.0),        # f reads t
}
DEFAULT_SET = ("double_pendulum", "pendulum")
# The models whose taylor series run in lanes (K factored in the compact layout, every order
# written out: c_taylor_lanes.py); the others' taylor sweeps run member by member.
TAYLOR_LANE_MODELS = ("double_pendulum", "kepler", "elastic_pendulum", "heavy_top", "cart_pole")
MEMBERS = 100


def draw(ranges: dict, count: int, seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {name: rng.uniform(low, high, count) for name, (low, high) in ranges.items()}


def simulated(model, scene: str, values: dict, stop: float, integrator: str = "dop853", **options):
    """(values, status, counters) of simulate(); a failure's partial rows and its message."""
    try:
        result, status = model.simulate(scene, set=values, stop=stop, integrator=integrator, **options), "ok"
    except SimulationError as error:
        result, status = error.partial, None
    return result, status


@pytest.mark.parametrize("integrator,name,options",
                         [pytest.param("dop853", name, {}, marks=() if name in DEFAULT_SET else pytest.mark.slow)
                          for name in LANE_MODELS]
                         + [pytest.param("taylor", name, {}, marks=() if name == "double_pendulum" else pytest.mark.slow)
                            for name in TAYLOR_LANE_MODELS]
                         + [pytest.param("taylor", name, {"norm": "state"},
                                         marks=() if name == "kepler" else pytest.mark.slow, id=f"taylor-{name}-state")
                            for name in TAYLOR_LANE_MODELS])
def test_each_member_of_a_lane_sweep_equals_its_simulate_bit_for_bit(integrator, name, options):
    scene, ranges, stop = LANE_MODELS[name]
    model = library_model(name)
    # 1, or for taylor the condition that the build is a double one (c_taylor_lanes.py)
    assert "#define LAG_HAS_LANES 0" not in model.emit("c", scene, Overrides(integrator=integrator)).text
    varied = draw(ranges, MEMBERS, seed=len(name))
    sweep = model.sweep(scene, set=varied, stop=stop, integrator=integrator, workers=2, **options)
    for b in range(MEMBERS):
        result, status = simulated(model, scene, {k: v[b] for k, v in varied.items()}, stop, integrator, **options)
        rows = len(result.t)
        assert np.array_equal(sweep.values[b, :rows], result.values, equal_nan=True), (name, b)
        assert np.all(np.isnan(sweep.values[b, rows:]))
        assert (sweep.status[b] == "ok") == (status == "ok"), (name, b, sweep.status[b])
        for counter, counts in sweep.counters.items():
            assert counts[b] == result.summary.count(counter), (name, b, counter)


@pytest.mark.parametrize("integrator", ["dop853", "taylor"])
def test_members_that_fail_end_alone_and_their_neighbours_in_the_lanes_go_on(integrator):
    model = library_model("double_pendulum")
    masses = np.where(np.arange(40) % 3 == 0, 0.0, 1.0)       # m1 = m2 = 0: M singular from the start
    varied = {"m1": masses, "m2": masses, "theta1.start": np.linspace(-2, 2, 40)}
    sweep = model.sweep("chaos", set=varied, stop=2.0, integrator=integrator)
    failed = np.flatnonzero(sweep.status != "ok")
    assert list(failed) == list(np.flatnonzero(masses == 0))
    for b in (0, 1, 2):
        result, status = simulated(model, "chaos", {k: v[b] for k, v in varied.items()}, 2.0, integrator)
        assert np.array_equal(sweep.values[b, :len(result.t)], result.values, equal_nan=True)
        assert (status == "ok") == (sweep.status[b] == "ok")


def test_the_lane_system_keeps_libm_calls_out_of_the_loops_that_vectorise():
    """The statements are grouped so that no arithmetic loop holds a call, each read is defined
    in an earlier group (or is an input), and each statement appears once."""
    from lagdsl.codegen.c import CPrinter, _print_block, signature
    model = library_model("double_pendulum")
    kernel = lower_to_kernel(model.equations, model.plan("chaos", Overrides()))
    printed = _print_block(kernel.system, signature(kernel, "system"), kernel, CPrinter())
    kept, groups = lane_groups(kernel.system, printed)
    statements = [target for group in groups for target, _ in group.statements]
    assert len(statements) == len(set(statements)) == len(printed["assignments"]) + len(printed["stores"])
    calls = [any("r_sin(" in value or "r_cos(" in value for _, value in group.statements) for group in groups]
    assert calls == [number % 2 == 1 for number in range(len(groups))]
    defined = set()
    for group in groups:
        assert {name for name, _ in group.reads} - {"t"} <= defined | {name for name, _ in kernel.system.inputs}
        defined |= {target for target, _ in group.statements}
    assert set(kept) <= defined


SWEEP = """
import numpy as np, lagdsl, resource, sys
model = lagdsl.load(sys.argv[1])
s = model.sweep("swing", set={"theta.start": np.linspace(-3, 3, int(sys.argv[2]))}, stop=0.05, interval=0.05,
                integrator="dop853")
size = s.values.nbytes + s.failure_time.nbytes + s.rows.nbytes + sum(c.nbytes for c in s.counters.values())
print(len(s), int(np.sum(s.status != "ok")), size, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
"""


@pytest.mark.slow
def test_a_lane_sweep_of_100000_members_takes_the_size_of_its_result_plus_a_constant():
    """The lanes hold a few members per thread, whatever the sweep's size: the peak resident
    memory of 10^5 members exceeds that of 10^3 by a small multiple of the result's arrays (its
    values, counters, statuses and summaries), not by anything per member of the lanes."""
    few, many = (_sweep_memory(count) for count in (10**3, 10**5))
    assert many[:2] == (10**5, 0)
    growth_kb = many[3] - few[3]
    assert growth_kb * 1024 < 6 * many[2] + 32 * 2**20, (growth_kb, many[2])


def _sweep_memory(count: int) -> tuple[int, int, int, int]:
    """(members, failed, bytes of the result's arrays, peak resident kilobytes) of a sweep of `count`."""
    out = subprocess.run([sys.executable, "-c", SWEEP, str(MODELS / "pendulum.lag"), str(count)],
                         capture_output=True, text=True, check=True)
    members, failed, size, peak = (int(x) for x in out.stdout.split())
    return members, failed, size, peak
