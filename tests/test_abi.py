"""The contract between Python and the generated C (lagdsl/abi.py), checked from both sides: the C
words each status as SimulationError does, reads the constants settings.py has, and packs the
summary where Python's record of the layout reads it."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from lagdsl import settings
from lagdsl.abi import SETTINGS, STATUSES, UNKNOWN_STATUS, summary_layout
from lagdsl.codegen.c_abi import runtime_contract, runtime_header, status_printer
from lagdsl.integrators import registry
from tests.run.c_harness import STRICT_FLAGS, SYSTEM_HEADERS, find_cc
from tests.conftest import compiled

MAIN = r"""
int main(void)
{
    int status;
    (void)r_isfinite;       /* the runtime's, unused here */
    (void)lag_print_real;
    for (status = 0; status <= %(last)d; ++status) {
        lag_print_status(stdout, status, 123L, 1.5e-14, 4.5e6, 12.5);
        putchar('\n');
    }
    printf("%%ld %%ld %%ld %%.17g %%d %%.17g %%d %%.17g %%d\n", LAG_MAX_ROWS, LAG_DEFAULT_MAX_STEPS,
           LAG_STEPS_PER_ROW, (double)LAG_GRID_SLACK, LAG_RTOL_FLOOR_EPS, (double)LAG_RTOL_FLOOR, LAG_MIN_STEP_EPS,
           (double)LAG_RCOND_MIN, LAG_SETTINGS);
    return 0;
}
"""


@pytest.fixture(scope="module")
def printed(tmp_path_factory) -> list[str]:
    """The lines of a C program that prints every status (and one past the table) and the constants."""
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    work = tmp_path_factory.mktemp("abi")
    source, program = work / "abi.c", work / "abi"
    source.write_text("\n".join([SYSTEM_HEADERS, runtime_header(), runtime_contract(), status_printer(),
                                 MAIN % {"last": max(STATUSES) + 1}]))
    compiled([cc, *STRICT_FLAGS, str(source), "-o", str(program), "-lm"], check=True)
    return subprocess.run([str(program)], check=True, capture_output=True, text=True).stdout.splitlines()


def test_the_c_program_words_every_status_as_python_does(printed):
    for code, status in STATUSES.items():
        rcond = 1.5e-14 if status.detail else None
        assert printed[code] == status.describe(123, rcond, 4.5e6, 12.5)
    assert printed[max(STATUSES) + 1] == UNKNOWN_STATUS.message


def test_the_c_constants_are_those_of_settings(printed):
    values = printed[-1].split()
    assert [int(values[0]), int(values[1]), int(values[2])] == [settings.MAX_ROWS, settings.DEFAULT_MAX_STEPS,
                                                                 settings.STEPS_PER_ROW]
    assert float(values[3]) == settings.GRID_SLACK
    assert int(values[4]) == settings.RTOL_FLOOR_EPS and float(values[5]) == settings.RTOL_FLOOR
    assert int(values[6]) == settings.MIN_STEP_EPS and float(values[7]) == settings.RCOND_MIN
    assert int(values[8]) == len(SETTINGS)
    assert settings.RCOND_MIN == settings.RCOND_MIN_EPS * sys.float_info.epsilon


@pytest.mark.parametrize("integrator", registry.names())
@pytest.mark.parametrize("invariants, constraints, stop", [(0, False, False), (1, True, True), (3, False, True)])
def test_the_record_dtype_reads_each_field_at_its_offset(integrator, invariants, constraints, stop):
    layout = summary_layout(integrator, invariants, 6, constraints, stop)
    summaries = layout.empty(2)
    doubles = summaries.view(np.float64).reshape(2, layout.size)
    doubles[:] = np.arange(2 * layout.size).reshape(2, layout.size)
    assert summaries.dtype.itemsize == 8 * layout.size
    for field in layout.fields:
        at = layout.offset(field.name)
        read = summaries[field.name][1]
        assert np.array_equal(np.atleast_1d(read), doubles[1, at:at + field.size])
        assert np.shape(read) == ((field.size,) if field.array else ())
    assert layout.counters == registry.get(integrator).counters
    counters = [layout.offset(counter) for counter in layout.counters]
    assert counters == list(range(counters[0], counters[0] + len(counters)))     # contiguous, as C reads them


@pytest.mark.parametrize("integrator", registry.names())
def test_no_remedy_offers_a_run_the_method_it_used(integrator):
    """radau5 and auto are never told to try radau5; the explicit methods are, for a stiff problem."""
    remedies = [status.remedy_for(integrator) for status in STATUSES.values()]
    assert not any(f"--integrator {integrator}" in remedy or "{" in remedy for remedy in remedies)
    record = registry.get(integrator)
    suggests_radau5 = any("--integrator radau5" in remedy for remedy in remedies)
    assert suggests_radau5 == (not record.implicit and not record.fixed_step)
