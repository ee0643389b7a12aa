"""The build cache: damaged or foreign entries are rebuilt, an unusable cache is replaced, builders do not collide.

A damaged shared library must never be loaded by a process that had loaded it before (the
mapping would break), so the C cases run `lagc` in fresh processes.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import stat
import subprocess
import sys
import threading

import numpy as np
import pytest

import lagdsl
from lagdsl.run import cache
from tests.conftest import lagc_in_process, own_cache
from tests.run.test_output_files import OSCILLATOR

ANHARMONIC = OSCILLATOR.replace("U = x^2/2;", "U = x^4/4;").replace("Oscillator", "Anharmonic")


def counting_builder(built: list, text: str = "entry\n", together: threading.Barrier | None = None):
    def build(path):
        if together is not None:
            together.wait(timeout=120)      # every builder is inside build before any writes its entry
        built.append(path)
        path.write_text(text)
    return build


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    return own_cache(monkeypatch, tmp_path / "cache")


def test_an_entry_is_built_once_and_reused(cache_dir):
    built = []
    first = cache.cached_entry("a-1.txt", "1" * 64, counting_builder(built))
    second = cache.cached_entry("a-1.txt", "1" * 64, counting_builder(built))
    assert first == second == cache_dir / "a-1.txt" and len(built) == 1
    assert sorted(os.listdir(cache_dir)) == ["a-1.txt", "a-1.txt.manifest"]


@pytest.mark.parametrize("damage", ["truncate", "no manifest", "garbage manifest", "foreign entry"])
def test_a_damaged_or_foreign_entry_is_rebuilt(cache_dir, damage):
    built = []
    entry = cache.cached_entry("a-1.txt", "1" * 64, counting_builder(built, "the right entry\n"))
    manifest = entry.with_name(entry.name + ".manifest")
    if damage == "truncate":
        entry.write_bytes(entry.read_bytes()[:3])
    elif damage == "no manifest":
        manifest.unlink()
    elif damage == "garbage manifest":
        manifest.write_bytes(b"\xff{")
    else:   # another key's entry and manifest copied in under this name
        other = cache.cached_entry("b-2.txt", "2" * 64, counting_builder(built, "another entry\n"))
        shutil.copy(other, entry)
        shutil.copy(other.with_name(other.name + ".manifest"), manifest)
        built.clear()
    assert cache.cached_entry("a-1.txt", "1" * 64, counting_builder(built, "the right entry\n")) == entry
    assert len(built) == (1 if damage == "foreign entry" else 2)
    assert entry.read_text() == "the right entry\n"


def test_concurrent_builders_in_threads_do_not_collide(cache_dir):
    built, results, together = [], [], threading.Barrier(6)
    threads = [threading.Thread(target=lambda: results.append(
        cache.cached_entry("a-1.txt", "1" * 64, counting_builder(built, together=together)))) for _ in range(6)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(built) == 6 and len(results) == 6 and (cache_dir / "a-1.txt").read_text() == "entry\n"
    assert not [name for name in os.listdir(cache_dir) if name.startswith(".")]


def test_an_unwritable_cache_falls_back_to_a_private_one(tmp_path, monkeypatch, capsys):
    # As root, mode bits do not stop writes; a cache path below a regular file cannot be created by anyone.
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("LAGDSL_CACHE", str(tmp_path / "file" / "cache"))
    model = tmp_path / "oscillator.lag"
    model.write_text(OSCILLATOR)
    result = lagdsl.load(model).simulate(backend="numpy")
    lagdsl.load(model).simulate(backend="numpy")
    assert np.allclose(result["x"], np.cos(result.t), atol=1e-5)
    warnings = capsys.readouterr().err.splitlines()
    assert len(warnings) == 1 and warnings[0].startswith(f"lagc: warning: cannot use the build cache '{tmp_path}")


def test_a_truncated_numpy_module_is_rebuilt(cache_dir, tmp_path):
    model = tmp_path / "oscillator.lag"
    model.write_text(OSCILLATOR)
    first = lagdsl.load(model).simulate(backend="numpy")
    (module,) = cache_dir.glob("*.py")
    module.write_text(module.read_text()[:100])
    second = lagdsl.load(model).simulate(backend="numpy")
    assert np.array_equal(first.values, second.values)
    assert "def rhs" in module.read_text()


def lagc_run(model, cache_dir):
    """`lagc run MODEL`'s CSV from a fresh process, which has no library loaded yet."""
    done = subprocess.run([sys.executable, "-m", "lagdsl", "run", str(model)], capture_output=True, text=True,
                          env={**os.environ, "LAGDSL_CACHE": str(cache_dir)})
    assert done.returncode == 0, done.stderr
    return done.stdout


def built_here(model) -> str:
    """`lagc run MODEL`'s CSV from this process, which builds into $LAGDSL_CACHE without a new
    interpreter to start; the library stays mapped here, so a test replaces it by a new file."""
    done = lagc_in_process("run", model)
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.slow
def test_damaged_or_foreign_libraries_are_rebuilt_and_run_correctly(cache_dir, tmp_path):
    model, other = tmp_path / "oscillator.lag", tmp_path / "anharmonic.lag"
    model.write_text(OSCILLATOR)
    other.write_text(ANHARMONIC)
    expected = lagc_run(model, cache_dir)
    lagc_run(other, cache_dir)
    (library,) = cache_dir.glob("Oscillator_*.so")
    (foreign,) = cache_dir.glob("Anharmonic_*.so")
    library.write_bytes(library.read_bytes()[:1000])                 # truncated
    assert lagc_run(model, cache_dir) == expected
    shutil.copy(foreign, library)                                    # another model's library under this key
    assert lagc_run(model, cache_dir) == expected


@pytest.mark.slow
def test_two_processes_building_the_same_model_both_succeed(cache_dir, tmp_path):
    model = tmp_path / "oscillator.lag"
    model.write_text(OSCILLATOR)
    command = [sys.executable, "-m", "lagdsl", "run", str(model)]
    environment = {**os.environ, "LAGDSL_CACHE": str(cache_dir)}
    runs = [subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environment)
            for _ in range(2)]
    outputs = [run.communicate() for run in runs]
    assert [run.returncode for run in runs] == [0, 0], outputs
    assert outputs[0][0] == outputs[1][0] and outputs[0][0].startswith("t,x\n")
    # one library and one plan (run/plans.py), no build left behind; the plan serves the next run
    assert len(list(cache_dir.glob("*.so"))) == len(list(cache_dir.glob("plan-*.json"))) == 1
    assert not [path for path in cache_dir.iterdir() if path.name.startswith(".")]
    assert lagc_run(model, cache_dir) == outputs[0][0]


PLANTED = """#include <stdio.h>
#include <stdlib.h>
__attribute__((constructor)) static void planted(void) { FILE *f = fopen(getenv("PLANTED_MARK"), "w"); if (f) fclose(f); }
int lag_run(void) { return 0; }
"""


def plant(library, tmp_path):
    """Replace `library` by one whose constructor leaves a mark, with a manifest that vouches for it."""
    source = tmp_path / "planted.c"
    source.write_text(PLANTED)
    subprocess.run(["cc", "-shared", "-fPIC", "-o", str(library), str(source)], check=True)
    manifest = library.with_name(library.name + ".manifest")
    record = json.loads(manifest.read_text())
    record["sha256"] = hashlib.sha256(library.read_bytes()).hexdigest()
    manifest.write_text(json.dumps(record) + "\n")


@pytest.mark.parametrize("how", [pytest.param("directory writable by others", marks=pytest.mark.slow),
                                 "entry writable by others",
                                 pytest.param("directory of another user", marks=pytest.mark.slow)])
def test_code_planted_in_an_untrusted_cache_is_never_loaded(cache_dir, tmp_path, how):
    if how == "directory of another user" and os.getuid() != 0:
        pytest.skip("only root can give the cache to another user")
    model = tmp_path / "oscillator.lag"
    model.write_text(OSCILLATOR)
    expected = built_here(model)
    assert stat.S_IMODE(cache_dir.stat().st_mode) == 0o700          # created private
    (library,) = cache_dir.glob("Oscillator_*.so")
    plant(library, tmp_path)
    if how == "directory writable by others":
        cache_dir.chmod(0o777)
    elif how == "entry writable by others":
        library.chmod(0o666)
    else:
        os.chown(cache_dir, 4321, 4321)
    mark = tmp_path / "planted-code-ran"
    done = subprocess.run([sys.executable, "-m", "lagdsl", "run", str(model)], capture_output=True, text=True,
                          env={**os.environ, "LAGDSL_CACHE": str(cache_dir), "PLANTED_MARK": str(mark)})
    assert done.returncode == 0 and done.stdout == expected, done.stderr
    assert not mark.exists()
    if how != "entry writable by others":
        assert done.stderr.count("cannot use the build cache") == 1
        assert ("writable by others" if how.startswith("directory writable") else "owned by another user") \
            in done.stderr


@pytest.mark.slow         # a vouched-for library of another's making: test_code_planted_in_an_untrusted_cache_is_never_loaded
def test_a_library_without_the_entry_point_is_rebuilt(cache_dir, tmp_path):
    model = tmp_path / "oscillator.lag"
    model.write_text(OSCILLATOR)
    expected = lagc_run(model, cache_dir)
    (library,) = cache_dir.glob("Oscillator_*.so")
    plant(library, tmp_path)
    source = tmp_path / "empty.c"
    source.write_text("int lag_something_else(void) { return 0; }\n")
    subprocess.run(["cc", "-shared", "-fPIC", "-o", str(library), str(source)], check=True)
    manifest = library.with_name(library.name + ".manifest")
    record = json.loads(manifest.read_text())
    record["sha256"] = hashlib.sha256(library.read_bytes()).hexdigest()
    manifest.write_text(json.dumps(record) + "\n")
    assert lagc_run(model, cache_dir) == expected
    result = lagdsl.load(model).simulate()
    assert result.values.shape[0] == 3


def test_a_model_with_a_name_of_250_characters_runs(cache_dir, tmp_path):
    name = "Oscillator" + "x" * 240
    model = tmp_path / "long.lag"
    model.write_text(OSCILLATOR.replace("Oscillator", name))
    first = built_here(model)
    assert first.startswith("t,x\n") and lagc_run(model, cache_dir) == first
    assert all(len(path.name) < 255 for path in cache_dir.iterdir())


def test_a_dangling_build_link_does_not_stop_cache_clear(cache_dir, capsys):
    cache.cached_entry("a-" + "1" * 20 + ".py", "1" * 64, counting_builder([]))
    (cache_dir / ".build-dangling").symlink_to(cache_dir / "nowhere")
    assert cache.clear() == 1
    assert not os.path.lexists(cache_dir / ".build-dangling")
