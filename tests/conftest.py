"""Shared fixtures and helpers: model paths, loading, the --update-golden option."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"


def without_units(text: str) -> str:
    """A model's text with its unit annotations removed: a model without units is not checked
    dimensionally (for tests that change a model in ways its units would not allow)."""
    return re.sub(r"(?<=[ \t])\[[^\]\n]*\]", "", text)


def pytest_addoption(parser):
    parser.addoption("--update-golden", action="store_true", default=False,
                     help="rewrite tests/golden/ from the current code generator")


@pytest.fixture
def update_golden(request) -> bool:
    return request.config.getoption("--update-golden")
