"""User text on the terminal: control and bidirectional characters are shown as escapes, never
sent raw (a description must not clear the screen, recolour it or reorder what is shown)."""
from __future__ import annotations

import re

from lagdsl.cli import main as lagc
from tests.conftest import MODELS

HIDDEN = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")   # all but tab and newline
MODEL = """model Spring "\x1b[2Jcleared\u202e"
  parameter k = 1.0 [1/s^2] "\x07stiff";
  coordinate x(start = 1) [kg^(1/2)*m] "\x1b]0;title\x07";
  T = der(x)^2/2;
  U = k*x^2/2;
  scene s "\x9b31m"
    output x;
  end s;
end Spring;
"""


def run(tmp_path, capsys, text, *command):
    path = tmp_path / "spring.lag"
    path.write_text(text, encoding="utf-8")
    status = lagc([*command, str(path)])
    return status, capsys.readouterr()


def test_check_and_eom_show_control_characters_as_escapes(tmp_path, capsys):
    status, shown = run(tmp_path, capsys, MODEL, "check")
    assert status == 0
    assert not HIDDEN.search(shown.out)
    assert '"\\x1b[2Jcleared\\u202e"' in shown.out and '"\\x9b31m"' in shown.out
    assert "\\x1b]0;title\\x07" in shown.out
    status, shown = run(tmp_path, capsys, MODEL, "eom")
    assert status == 0 and not HIDDEN.search(shown.out)


def test_error_messages_show_control_characters_with_the_caret_in_place(tmp_path, capsys):
    text = MODEL.replace('  U = k*x^2/2;', '  U = k*x^2/2; let y = "\x1b[31m" + zz;')
    status, shown = run(tmp_path, capsys, text, "check")
    assert status == 1 and not HIDDEN.search(shown.err)
    lines = shown.err.splitlines()
    source, caret = next((lines[i + 1], lines[i + 2]) for i, line in enumerate(lines) if "error:" in line)
    assert "\\x1b[31m" in source
    assert caret.index("^") == source.index('"\\x1b')


def test_a_missing_file_with_control_characters_in_its_name(tmp_path, capsys):
    assert lagc(["check", str(tmp_path / "\x1b[2J.lag")]) == 1
    error = capsys.readouterr().err
    assert "\\x1b[2J.lag" in error and not HIDDEN.search(error)


def test_control_characters_in_an_option_or_an_output_path_reach_the_terminal_escaped(tmp_path, capsys):
    model = tmp_path / "pendulum.lag"
    model.write_text((MODELS / "pendulum.lag").read_text())
    assert lagc(["run", str(model), "--integrator", "dop\x1b[31m853"]) == 1
    assert lagc(["run", str(model), "-o", str(tmp_path / "no\x1b[2Jdir" / "out.csv")]) == 1
    err = capsys.readouterr().err
    assert "\x1b" not in err and err.count("\\x1b") == 4      # the label and the name, the path twice
