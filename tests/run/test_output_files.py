"""Writing results (`-o`, `Result.to_csv`): regular files replaced atomically, everything else kept.

The process may run as root, which may write any file: read-only files must still be refused.
"""
from __future__ import annotations

import os
import stat
import threading

import pytest

from lagdsl.cli import main
from lagdsl.run.files import CannotWrite, write_output
from tests.conftest import model_file

OSCILLATOR = """model Oscillator
  coordinate x(start = 1);
  T = der(x)^2/2;
  U = x^2/2;
  scene short
    time(stop = 0.5, interval = 0.25);
    integrator rk4(step = 0.05);
    output x;
  end short;
end Oscillator;
"""


@pytest.fixture
def model():
    return model_file(OSCILLATOR, "oscillator")


def leftovers(directory) -> list[str]:
    return [name for name in os.listdir(directory) if name.endswith(".tmp")]


def test_a_new_file_gets_the_default_mode(tmp_path):
    umask = os.umask(0o022)
    try:
        write_output(tmp_path / "new.csv", "a\n")
    finally:
        os.umask(umask)
    assert (tmp_path / "new.csv").read_text() == "a\n"
    assert stat.S_IMODE((tmp_path / "new.csv").stat().st_mode) == 0o644


def test_a_replaced_file_keeps_its_mode(tmp_path):
    path = tmp_path / "out.csv"
    path.write_text("old\n")
    path.chmod(0o640)
    write_output(path, "new\n")
    assert path.read_text() == "new\n"
    assert stat.S_IMODE(path.stat().st_mode) == 0o640
    assert leftovers(tmp_path) == []


def test_a_symlink_is_written_through_and_kept(tmp_path):
    target, link = tmp_path / "target.csv", tmp_path / "link.csv"
    target.write_text("old\n")
    link.symlink_to(target.name)
    write_output(link, "new\n")
    assert link.is_symlink() and os.readlink(link) == target.name
    assert target.read_text() == "new\n"


def test_a_fifo_is_written_in_place(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    received = []
    reader = threading.Thread(target=lambda: received.append(fifo.read_text()))
    reader.start()
    write_output(fifo, "through the pipe\n")
    reader.join(timeout=10)
    assert received == ["through the pipe\n"]
    assert stat.S_ISFIFO(fifo.lstat().st_mode)


def test_a_read_only_file_is_refused_and_left_alone(tmp_path):
    path = tmp_path / "kept.csv"
    path.write_text("precious\n")
    path.chmod(0o444)
    with pytest.raises(CannotWrite) as refusal:
        write_output(path, "new\n")
    assert str(path) in str(refusal.value) and "read-only" in str(refusal.value)
    assert path.read_text() == "precious\n" and stat.S_IMODE(path.stat().st_mode) == 0o444
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("where, reason", [("missing/out.csv", "does not exist"), (".", "it is a directory")])
def test_what_cannot_be_a_file_is_refused(tmp_path, where, reason):
    with pytest.raises(CannotWrite, match=reason):
        write_output(tmp_path / where, "x\n")
    assert leftovers(tmp_path) == []


def test_run_refuses_a_read_only_output_naming_the_users_path(model, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out.csv").write_text("precious\n")
    (tmp_path / "out.csv").chmod(0o400)
    assert main(["run", str(model), "-o", "out.csv"]) == 1
    assert capsys.readouterr().err.strip() == "lagc: error: cannot write 'out.csv': the file is read-only"
    assert (tmp_path / "out.csv").read_text() == "precious\n"
    assert main(["run", str(model), "-o", "nowhere/out.csv"]) == 1
    assert "lagc: error: cannot write 'nowhere/out.csv': the directory" in capsys.readouterr().err
    assert leftovers(tmp_path) == []


def test_run_to_dev_null_keeps_the_device(model, capsys):
    assert main(["run", str(model), "-o", os.devnull]) == 0
    assert stat.S_ISCHR(os.stat(os.devnull).st_mode)


def test_emit_to_a_symlink_writes_the_target(model, tmp_path):
    target, link = tmp_path / "model.c", tmp_path / "link.c"
    target.write_text("")
    link.symlink_to(target)
    assert main([str(model), "--emit", "c", "-o", str(link)]) == 0
    assert link.is_symlink() and "Oscillator" in target.read_text()


@pytest.mark.parametrize("arguments, limit", [
    pytest.param(["run", "MODEL", "--stop", "20000", "--interval", "0.01"], 1 << 22,   # 4 MiB: room to build the code,
                 marks=pytest.mark.slow),                                      # not for the table (a cold build)
    (["MODEL", "--emit", "c"], 4096),
])
def test_a_file_size_limit_on_standard_output_is_an_error_not_a_short_table(model, tmp_path, arguments, limit):
    """Under `ulimit -f` (a full disk does the same) the write stops part way: lagc says so, exit 1."""
    import resource
    import subprocess
    import sys

    command = [sys.executable, "-m", "lagdsl", *(str(model) if a == "MODEL" else a for a in arguments)]
    with open(tmp_path / "out", "wb") as out:
        done = subprocess.run(command, stdout=out, stderr=subprocess.PIPE, text=True,
                              preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit)),
                              env={**os.environ, "LAGDSL_CACHE": str(tmp_path / "cache")})
    assert done.returncode == 1, done.stderr
    assert "lagc: error: cannot write standard output: file too large" in done.stderr
    assert "Traceback" not in done.stderr


@pytest.mark.parametrize("where, reason", [
    ("", "the file name is empty"),
    ("sub/", "the name ends in '/', a directory"),
    ("MODEL", "it is the model file itself"),
])
def test_outputs_that_cannot_be_right_are_refused_before_the_run(model, tmp_path, capsys, where, reason):
    target = str(model) if where == "MODEL" else (f"{tmp_path}/{where}" if where else "")
    before = model.read_text()
    assert main(["run", str(model), "-o", target]) == 1
    assert f"cannot write '{target}': {reason}" in capsys.readouterr().err
    assert model.read_text() == before


def test_a_directory_where_no_file_can_be_made_is_refused_before_the_run(model, tmp_path, capsys, monkeypatch):
    """check_writable creates (and removes) the temporary file write_output will need."""
    original = os.open

    def refuse_in_locked(path, flags, mode=0o777, **kwargs):
        if "locked" in os.fspath(path) and flags & os.O_CREAT:
            raise PermissionError(13, "Permission denied")
        return original(path, flags, mode, **kwargs)

    (tmp_path / "locked").mkdir()
    monkeypatch.setattr(os, "open", refuse_in_locked)
    simulated = []
    monkeypatch.setattr("lagdsl.cli.common.load_model", lambda source: simulated.append(source))
    assert main(["run", str(model), "-o", str(tmp_path / "locked" / "out.csv")]) == 1
    assert "permission denied" in capsys.readouterr().err and simulated == []
