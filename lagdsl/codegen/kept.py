"""Generated sources kept across processes: a new process that loads a model and runs a scene it
ran before neither lowers nor prints it again.

Lowering (common subexpressions, Taylor recurrences) and printing take from a tenth of a second
to seconds a scene (12 s for the spring chain's Taylor series), in every process, while the text
they give depends only on what the code plan is made from: the model's text and file name, the
scene and the integrator asked for with its options, whether the draw statements are computed,
the backend, and lagdsl itself (parameters, start values, the time grid and tolerances are inputs
of the code at run time, api.Model._program). So the text is kept in the build cache (cache.py:
verified on every use, written atomically) under the SHA-256 of those inputs; lagdsl enters
through cache.package_digest, so that an edited code generator never finds an old text.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
from collections.abc import Callable

from ..run.cache import cached_entry, find_entry, package_digest, quiet_root
from ..settings import Overrides
from ..source import SourceFile
from . import GeneratedSource

KEPT_FORMAT = 1


def kept_source(model: SourceFile, scene: str | None, overrides: Overrides, drawn: bool, backend: str,
                generate: Callable[[], GeneratedSource]) -> GeneratedSource:
    """The source `generate()` gives for the code plan of `scene` with `overrides` (`drawn`: with
    the draw statements' columns) on `backend` (for an FMU, its FMI version and kinds: "fmi2-me-cs",
    lagdsl/fmu.py): from the cache when a process made it before, else generated and kept. Only
    the integrator and its options may be overridden: values and the time grid are not inputs of
    the key."""
    assert settles_code_only(overrides), "the key leaves out values and the time grid"
    if quiet_root() is None:       # an unusable cache: `lagc emit` builds nothing and says nothing of it
        return generate()
    key = _key(model, scene, overrides, drawn, backend)
    name = f"source-{key[:20]}.json"
    found = find_entry(name, key)
    if found is not None:
        record = json.loads(found.read_text(encoding="utf-8"))
        return GeneratedSource(record["language"], record["text"], record["suggested_name"])
    source = generate()
    record = {"language": source.language, "text": source.text, "suggested_name": source.suggested_name}
    with contextlib.suppress(OSError):     # not kept (a full disk, `ulimit -f`): only slower next time
        cached_entry(name, key, lambda path: path.write_text(json.dumps(record), encoding="utf-8"))
    return source


def settles_code_only(overrides: Overrides) -> bool:
    """`overrides` name no more than the integrator and its options (what a key covers)."""
    return not (overrides.values or overrides.atol_each or overrides.start is not None
                or overrides.stop is not None or overrides.interval is not None)


def _key(model: SourceFile, scene: str | None, overrides: Overrides, drawn: bool, backend: str) -> str:
    fields = json.dumps([KEPT_FORMAT, package_digest(), model.name, scene, overrides.integrator,
                         [list(option) for option in overrides.options], drawn, backend])
    return hashlib.sha256(f"{fields}\0{model.text}".encode()).hexdigest()
