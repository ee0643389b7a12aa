"""Answers of commands kept across processes: a warm `lagc check` imports neither sympy nor lark.

A command whose output depends only on the model's text (`lagc check`: the summary on standard
output, the unit notes on standard error) stores what it printed in the build cache
(`cache.py`), as a JSON entry beside the plans of `plans.py`. Its key is the SHA-256 of the
model's text, the name the messages give it (the path as written), the command, the answer
format, a digest of lagdsl itself (`cache.package_digest`) and where the packages the answer is
computed with are installed, with the size and time of their `__init__.py` (sympy prints the
expressions, pint names the units, lark parses; reading their versions from the package
metadata would cost a tenth of a second), so that an edited model or another lagdsl, sympy,
pint or lark never finds it. An entry is
verified as every cache entry is; a missing or damaged one is computed again and written.
A model with an error stores nothing: its message is computed each time.
"""
from __future__ import annotations

import hashlib
import importlib.util
import json
import os

from ..source import SourceFile
from .cache import cached_entry, find_entry, package_digest

ANSWER_FORMAT = 1
COMPUTED_WITH = ("sympy", "pint", "lark")       # the packages an answer depends on


def find(command: str, source: SourceFile) -> dict[str, str] | None:
    """The stored answer of `command` on this model text, if the cache holds a valid one."""
    key = _answer_key(command, source)
    entry = find_entry(_answer_name(command, key), key)
    try:
        return json.loads(entry.read_text(encoding="utf-8")) if entry else None
    except OSError:         # removed since it was verified (lagc cache clear): compute it again
        return None


def store(command: str, source: SourceFile, answer: dict[str, str]) -> None:
    """Write the answer entry (once; a valid one is kept)."""
    key = _answer_key(command, source)
    text = json.dumps(answer) + "\n"
    cached_entry(_answer_name(command, key), key, lambda path: path.write_text(text, encoding="utf-8"))


def _answer_name(command: str, key: str) -> str:
    return f"{command}-{key[:20]}.json"


def _answer_key(command: str, source: SourceFile) -> str:
    versions = [_installed(package) for package in COMPUTED_WITH]
    fields = json.dumps([ANSWER_FORMAT, package_digest(), command, source.name, versions])
    return hashlib.sha256(f"{fields}\0{source.text}".encode()).hexdigest()


def _installed(package: str) -> list:
    """Where `package` is installed, and the size and time of its `__init__.py`: a new version
    rewrites it."""
    spec = importlib.util.find_spec(package)
    origin = spec.origin if spec is not None else None
    if origin is None:
        return [package, None]
    status = os.stat(origin)
    return [origin, status.st_size, status.st_mtime_ns]
