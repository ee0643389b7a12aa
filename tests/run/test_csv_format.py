"""The CSV is the same bytes from `lagc run`, `Result.to_csv` and the standalone C program.

Numbers are printf's "%.17g" (which reads back to the same double): `0`, `1`, `-0`, `1e-300`,
`inf`, `-inf`, `nan`; header fields are quoted per RFC 4180 where they hold a comma or a quote.
"""
from __future__ import annotations

import csv
import io
import subprocess

import pytest

import lagdsl
from lagdsl.cli import main as lagc
from tests.conftest import compiled, model_file
from tests.run.c_harness import find_cc

# y stays at rest at 0, so -y is -0, 1/y is inf and -1/y is -inf; sqrt(x - 2) is NaN (printf
# writes glibc's sqrt(-1) as "-nan"); the last columns need quoting.
MODEL = """model Formats
  coordinate x(start = 1);
  coordinate y;
  T = der(x)^2/2 + der(y)^2/2;
  U = x^2/2;
  scene s
    time(stop = 0.2, interval = 0.1);
    integrator dop853;
    output x, -y, 1e-300*x, sqrt(x - 2), 1/y, -1/y, max(x, 0), sum(x /* "twice" */, i in 1:2);
  end s;
end Formats;
"""
COLUMNS = ["x", "-y", "1e-300*x", "sqrt(x - 2)", "1/y", "-1/y", "max(x, 0)", 'sum(x /* "twice" */, i in 1:2)']


@pytest.fixture
def model_path():
    return model_file(MODEL, "formats")


def test_lagc_run_to_csv_and_the_standalone_program_write_the_same_bytes(tmp_path, model_path):
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    assert lagc(["run", str(model_path), "-o", str(tmp_path / "run.csv")]) == 0
    lagdsl.load(model_path).simulate().to_csv(tmp_path / "api.csv")
    assert lagc([str(model_path), "--emit", "c", "-o", str(tmp_path / "formats.c")]) == 0
    compiled([cc, "-std=c99", "-O2", "-o", str(tmp_path / "formats"), str(tmp_path / "formats.c"), "-lm"], check=True)
    program = subprocess.run([str(tmp_path / "formats")], capture_output=True, check=True).stdout
    written = (tmp_path / "run.csv").read_bytes()
    assert written == (tmp_path / "api.csv").read_bytes() == program
    rows = list(csv.reader(io.StringIO(written.decode())))
    assert rows[0] == ["t", *COLUMNS]
    assert rows[1] == ["0", "1", "-0", "1e-300", "nan", "inf", "-inf", "1", "2"]
    assert rows[2][0] == "0.10000000000000001"


@pytest.mark.filterwarnings("ignore:divide by zero:RuntimeWarning", "ignore:invalid value:RuntimeWarning")
def test_the_numpy_backend_writes_the_same_format(tmp_path, model_path, capsys):
    assert lagc(["run", str(model_path), "--backend", "numpy"]) == 0
    rows = list(csv.reader(io.StringIO(capsys.readouterr().out)))
    assert rows[0] == ["t", *COLUMNS]
    assert rows[1] == ["0", "1", "-0", "1e-300", "nan", "inf", "-inf", "1", "2"]
    assert all(format(float(field), ".17g") == field for row in rows[1:] for field in row)
