"""The architecture walkthrough is executable documentation."""
import doctest

from tests.conftest import ROOT


def test_architecture_walkthrough():
    failures, _ = doctest.testfile(str(ROOT / "docs" / "architecture.md"), module_relative=False,
                                   optionflags=doctest.NORMALIZE_WHITESPACE)
    assert failures == 0
