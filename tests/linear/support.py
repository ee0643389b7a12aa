"""Helpers of the linear-analysis tests: one loaded model per library file, `lagc` in-process."""
from __future__ import annotations

from lagdsl.cli import main
from tests.conftest import library_model as model     # loaded once per session

__all__ = ["lagc", "model"]


def lagc(capsys, *arguments) -> tuple[int, str, str]:
    """Exit status, standard output and standard error of `lagc ARGUMENTS`."""
    status = main([str(a) for a in arguments])
    captured = capsys.readouterr()
    return status, captured.out, captured.err
