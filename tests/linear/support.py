"""Helpers of the linear-analysis tests: one loaded model per library file, `lagc` in-process."""
from __future__ import annotations

import functools

import lagdsl
from lagdsl.cli import main
from tests.conftest import MODELS


@functools.cache
def model(name: str) -> lagdsl.Model:
    return lagdsl.load(MODELS / f"{name}.lag")


def lagc(capsys, *arguments) -> tuple[int, str, str]:
    """Exit status, standard output and standard error of `lagc ARGUMENTS`."""
    status = main([str(a) for a in arguments])
    captured = capsys.readouterr()
    return status, captured.out, captured.err
