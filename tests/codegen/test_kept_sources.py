"""Generated sources kept across processes (codegen/kept.py): a model loaded again runs a scene
it ran before without lowering it, with the same result to the bit; an edited model, another
integrator or a damaged entry is generated anew."""
from __future__ import annotations

import numpy as np
import pytest

import lagdsl
from lagdsl.codegen import kernel
from lagdsl.source import SourceFile
from tests.conftest import MODELS, own_cache

PENDULUM = (MODELS / "double_pendulum.lag").read_text(encoding="utf-8")


@pytest.fixture
def cache(tmp_path, monkeypatch):
    return own_cache(monkeypatch, tmp_path / "cache")


@pytest.fixture
def lowerings(monkeypatch) -> list:
    """The scenes lowered from now on (by their integrator)."""
    lowered, lower = [], kernel.lower_to_kernel

    def counted(equations, plan):
        lowered.append(plan.integrator.name)
        return lower(equations, plan)
    monkeypatch.setattr(kernel, "lower_to_kernel", counted)
    return lowered


def loaded(text: str = PENDULUM) -> lagdsl.Model:
    """A new Model of `text`, as another process would load it."""
    return lagdsl.Model(SourceFile("double_pendulum.lag", text))


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_model_loaded_again_runs_without_lowering_and_gives_the_same_rows(cache, lowerings, backend):
    first = loaded().simulate(backend=backend, stop=1.0)
    assert lowerings == ["dop853"]
    again = loaded().simulate(backend=backend, stop=1.0, set={"theta1.start": 0.3})
    same = loaded().simulate(backend=backend, stop=1.0)
    assert lowerings == ["dop853"] and len(list(cache.glob("source-*.json"))) == 1
    assert np.array_equal(same.values, first.values) and not np.array_equal(again.values, first.values)
    assert loaded().emit(backend).text == loaded().emit(backend).text and lowerings == ["dop853", "dop853"]


def test_an_edited_model_another_integrator_or_other_options_are_generated_anew(cache, lowerings):
    """The options given are the standalone program's defaults, written in its source. The key is
    the same for both backends (but for the backend's name), so NumPy shows it without the four C
    builds; the C side of a kept source is test_a_model_loaded_again_...[c]'s."""
    loaded().simulate(backend="numpy", stop=0.1)
    loaded(PENDULUM.replace("parameter g  = 9.81", "parameter g  = 9.8")).simulate(backend="numpy", stop=0.1)
    loaded().simulate(backend="numpy", stop=0.1, integrator="radau5")
    loaded().simulate(backend="numpy", stop=0.2, integrator="radau5")
    loaded().simulate(backend="numpy", stop=0.1, integrator="radau5", rtol=1e-8)
    assert lowerings == ["dop853", "dop853", "radau5", "radau5"]


def test_a_damaged_entry_is_generated_again(cache, lowerings):
    first = loaded().simulate(stop=0.5)
    (kept,) = cache.glob("source-*.json")
    kept.write_text(kept.read_text().replace("lag_", "lug_"))
    again = loaded().simulate(stop=0.5)
    assert lowerings == ["dop853", "dop853"] and np.array_equal(again.values, first.values)


def test_an_untrusted_cache_is_neither_read_nor_written_nor_warned_of_by_emit(tmp_path, monkeypatch, capsys):
    """`lagc emit` builds nothing: a cache it cannot trust costs it only the time a kept source saves."""
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    monkeypatch.setenv("LAGDSL_CACHE", str(shared))
    assert loaded().emit("c").text == loaded().emit("c").text
    assert capsys.readouterr().err == "" and list(shared.iterdir()) == []
