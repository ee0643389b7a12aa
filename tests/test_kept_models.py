"""Derived models kept in the build cache (lagdsl/kept_models.py): a text derived before is read
back in a new Model, equal to a fresh derivation and generating the same code; a text with an
error, a derivation that warned, a damaged entry or an unusable cache store or read nothing."""
from __future__ import annotations

import warnings

import pytest

import lagdsl
from lagdsl import pipeline
from lagdsl.errors import LagError, LagWarning
from lagdsl.source import SourceFile
from tests.conftest import MODELS, own_cache


@pytest.fixture
def derivations(monkeypatch, tmp_path) -> list:
    """The texts pipeline.compile_model derives, in a cache of the test's own."""
    own_cache(monkeypatch, tmp_path / "cache")
    derived = []
    compile_model = pipeline.compile_model
    monkeypatch.setattr(pipeline, "compile_model", lambda source: derived.append(source.name) or compile_model(source))
    return derived


def entries(tmp_path) -> list[str]:
    return sorted(path.name for path in (tmp_path / "cache").glob("derived-*.pickle"))


def test_a_model_derived_before_is_read_back_and_generates_the_same_code(derivations, tmp_path):
    source = SourceFile.read(MODELS / "double_pendulum.lag")
    first, second = lagdsl.Model(source), lagdsl.Model(source)
    assert derivations == [source.name] and len(entries(tmp_path)) == 1
    assert second.equations.mass_matrix == first.equations.mass_matrix
    assert second.ir == first.ir
    for backend in ("c", "numpy"):
        assert second.emit(backend, "chaos").text == first.emit(backend, "chaos").text
    # another file name is another entry: diagnostics and the generated code name the file
    lagdsl.Model(SourceFile("elsewhere/double_pendulum.lag", source.text))
    assert len(derivations) == 2 and len(entries(tmp_path)) == 2


def test_a_text_with_an_error_stores_nothing_and_raises_each_time(derivations, tmp_path):
    broken = SourceFile("broken.lag", "model B\n  coordinate x;\n  T = der(y)^2;\nend B;\n")
    for _ in range(2):
        with pytest.raises(LagError, match="y"):
            lagdsl.Model(broken)
    assert derivations == ["broken.lag"] * 2 and entries(tmp_path) == []


def test_a_derivation_that_warned_is_not_kept_and_warns_each_time(derivations, tmp_path, monkeypatch):
    compile_model = pipeline.compile_model

    def warning(source):
        warnings.warn("a warning of the derivation", LagWarning)
        return compile_model(source)

    monkeypatch.setattr(pipeline, "compile_model", warning)
    source = SourceFile.read(MODELS / "pendulum.lag")
    for _ in range(2):
        with pytest.warns(LagWarning, match="a warning of the derivation"):
            lagdsl.Model(source)
    assert len(derivations) == 2 and entries(tmp_path) == []


def test_a_damaged_entry_is_derived_again_and_replaced(derivations, tmp_path):
    source = SourceFile.read(MODELS / "pendulum.lag")
    lagdsl.Model(source)
    [name] = entries(tmp_path)
    (tmp_path / "cache" / name).write_bytes(b"not a pickle")
    assert [str(q) for q in lagdsl.Model(source).equations.coordinates] == ["theta"]
    assert len(derivations) == 2 and entries(tmp_path) == [name]
    lagdsl.Model(source)
    assert len(derivations) == 2


def test_without_a_usable_cache_a_model_is_derived_and_nothing_is_said(derivations, tmp_path, recwarn):
    (tmp_path / "cache").write_text("a file where the cache should be")
    source = SourceFile.read(MODELS / "pendulum.lag")
    lagdsl.Model(source)
    lagdsl.Model(source)
    assert len(derivations) == 2 and not recwarn.list
