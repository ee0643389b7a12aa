"""Shared fixtures and helpers: model paths, loading, the --update-golden option."""
from __future__ import annotations

import os
import re
import shutil
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"


def without_units(text: str) -> str:
    """A model's text with its unit annotations removed: a model without units is not checked
    dimensionally (for tests that change a model in ways its units would not allow)."""
    return re.sub(r"(?<=[ \t])\[[^\]\n]*\]", "", text)


_TEMPORARY_CACHE = []


def pytest_configure(config):
    """The tests build into a temporary cache, removed at the end, never into the user's
    ~/.cache/lagdsl (a LAGDSL_CACHE set by the caller is used as it is; xdist's workers inherit
    this process's)."""
    if not os.environ.get("LAGDSL_CACHE"):
        _TEMPORARY_CACHE.append(tempfile.mkdtemp(prefix="lagdsl-tests-"))
        os.environ["LAGDSL_CACHE"] = os.path.join(_TEMPORARY_CACHE[0], "cache")


def pytest_unconfigure(config):
    for directory in _TEMPORARY_CACHE:
        shutil.rmtree(directory, ignore_errors=True)


def pytest_addoption(parser):
    parser.addoption("--update-golden", action="store_true", default=False,
                     help="rewrite tests/golden/ from the current code generator")


@pytest.fixture
def update_golden(request) -> bool:
    return request.config.getoption("--update-golden")
