"""Derived models kept across processes: a text derived before is read back, not parsed and
derived again.

Parsing a model and deriving its equations take from a tenth of a second to seconds in every
process that needs them (`lagc eom`, `lagc modes`, `lagc fit`, a first run, a Python session's
`Model`), while what they give depends only on the text, the file name its diagnostics and
generated code name, lagdsl itself and the packages it derives with. So the pair (ir.Model,
Equations) of pipeline.compile_model is pickled into the build cache (cache.py: verified on every
use, written atomically) under the SHA-256 of those inputs (run/answers.py's stamps of the
packages), and unpickled instead of derived when found. Unpickling runs code, as loading the
cache's libraries does: an entry is read only from a cache that cache.py trusts (owned by the
user, writable by no one else) and whose checksum holds. A text with an error stores nothing (its
diagnostics are computed each time), nor does one whose derivation warned or whose result does
not pickle (an expression nested too deeply for pickle's recursion).
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import pickle
import warnings

from .run.answers import package_stamps
from .run.cache import cached_entry, find_entry, package_digest, quiet_root
from .source import SourceFile

KEPT_FORMAT = 1
# What reading an entry back may raise besides a damaged file: a class lagdsl or sympy no longer
# has (a stamp would have changed first), an expression too deep for the unpickler.
UNREADABLE = (OSError, pickle.UnpicklingError, EOFError, AttributeError, ImportError, TypeError, RecursionError)


def compiled_model(source: SourceFile):
    """pipeline.compile_model(source): from the build cache when a process derived this text before,
    else derived and kept."""
    from .pipeline import compile_model
    if quiet_root() is None:            # no usable cache: derive, and say nothing of it
        return compile_model(source)
    key = _key(source)
    name = f"derived-{key[:20]}.pickle"
    found = find_entry(name, key)
    if found is not None:
        with contextlib.suppress(*UNREADABLE):
            return pickle.loads(found.read_bytes())
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        compiled = compile_model(source)
    for warning in said:                # said again, to the caller's filters
        warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)
    if not said:
        with contextlib.suppress(OSError, pickle.PicklingError, TypeError, AttributeError, RecursionError):
            data = pickle.dumps(compiled, protocol=pickle.HIGHEST_PROTOCOL)
            cached_entry(name, key, lambda path: path.write_bytes(data))
    return compiled


def _key(source: SourceFile) -> str:
    fields = json.dumps([KEPT_FORMAT, package_digest(), package_stamps(), source.name])
    return hashlib.sha256(f"{fields}\0{source.text}".encode()).hexdigest()
