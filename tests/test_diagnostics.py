"""Error quality of the front end: every malformed model in tests/diagnostics/ is rejected by
`lagc check` with exactly the diagnostics its comments announce.

Each file states what it expects, one comment line per diagnostic, in the order reported:

    // error: LINE:COLUMN: message

The check runs the command line's `main` (`lagc check FILE`, in this process: one interpreter
for the whole corpus) and requires exit status 1,
no Python traceback, the `file:line:column: error: message` lines equal to the expected ones,
and under each of them the offending source line and a caret at the column.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.conftest import ROOT, lagc_in_process

CORPUS = sorted((ROOT / "tests" / "diagnostics").glob("*.lag"))
EXPECTED = re.compile(r"^\s*//\s*error:\s*(\d+):(\d+):\s*(.*?)\s*$")


def expected_diagnostics(path: Path) -> list[tuple[int, int, str]]:
    found = []
    for line in path.read_text(encoding="utf-8").splitlines():
        match = EXPECTED.match(line)
        if match:
            found.append((int(match.group(1)), int(match.group(2)), match.group(3)))
    return found


def test_the_corpus_is_there():
    assert len(CORPUS) >= 30
    for path in CORPUS:
        assert expected_diagnostics(path), f"{path.name} announces no '// error: LINE:COLUMN: message'"


@pytest.mark.parametrize("path", CORPUS, ids=[p.stem for p in CORPUS])
def test_diagnostics(path: Path):
    done = lagc_in_process("check", path)
    assert "Traceback" not in done.stderr, done.stderr
    assert done.returncode == 1, done.stdout + done.stderr

    source_lines = path.read_text(encoding="utf-8").split("\n")
    stderr = done.stderr.splitlines()
    header = re.compile(rf"^{re.escape(str(path))}:(\d+):(\d+): error: (.*)$")
    reported = []
    for index, line in enumerate(stderr):
        match = header.match(line)
        if not match:
            continue
        number, column, message = int(match.group(1)), int(match.group(2)), match.group(3)
        reported.append((number, column, message))
        # Every diagnostic is followed by the offending line and a caret under the column.
        assert index + 2 < len(stderr), f"no source line and caret after: {line}"
        assert stderr[index + 1] == source_lines[number - 1], f"wrong source line after: {line}"
        caret = stderr[index + 2]
        assert re.fullmatch(r"[ \t]*\^~*", caret), f"no caret line after: {line}"
        assert caret.index("^") == column - 1, f"caret not at column {column}: {caret!r}"

    assert reported == expected_diagnostics(path), done.stderr
