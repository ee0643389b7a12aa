"""Answers of commands kept across processes: a warm `lagc check` or `lagc modes` imports
neither sympy nor lark.

A command whose output depends only on the model's text and its options (`lagc check`: the
summary on standard output, the unit notes on standard error; `lagc modes`: the table, the CSV,
the equilibrium found) stores what it printed in the build cache (`cache.py`), as a JSON entry
beside the plans of `plans.py`, with the warnings said while it was computed, which are said
again on each use. Its key is the SHA-256 of the model's text, the name the messages give it
(the path as written), the command and its options, the answer format, a digest of lagdsl itself (`cache.package_digest`) and where the packages the answer is
computed with are installed, with the size and time of their `__init__.py` (sympy prints the
expressions, pint names the units, lark parses, numpy and scipy solve the eigenproblems; reading their versions from the package
metadata would cost a tenth of a second), so that an edited model or another lagdsl, sympy,
pint, lark, numpy or scipy never finds it.
An entry is verified as every cache entry is; a missing or damaged one is computed again and
written. A model with an error stores nothing: its message is computed each time; nor does an
answer computed with a warning other than lagdsl's own.
"""
from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import warnings
from collections.abc import Callable

from ..errors import LagWarning
from ..source import SourceFile
from .cache import cached_entry, find_entry, package_digest

ANSWER_FORMAT = 1
COMPUTED_WITH = ("sympy", "pint", "lark", "numpy", "scipy")       # the packages an answer depends on
Answer = dict[str, str]


def kept(command: str, source: SourceFile, options: list, compute: Callable[[], Answer]) -> Answer:
    """The answer of `command` with `options` on this model text: the stored one, or compute()'s,
    stored then; the warnings said while computing it are said again (LagWarning) each time."""
    answer = find(command, source, options)
    if answer is None:
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            answer = compute()
        foreign = [warning for warning in said if not issubclass(warning.category, LagWarning)]
        for warning in foreign:
            warnings.showwarning(warning.message, warning.category, warning.filename, warning.lineno)
        messages = list(dict.fromkeys(str(warning.message) for warning in said if warning not in foreign))
        answer = {**answer, "warnings": messages}
        if not foreign:
            store(command, source, options, answer)
    for message in answer["warnings"]:
        warnings.warn(message, LagWarning, stacklevel=2)
    return answer


def find(command: str, source: SourceFile, options: list) -> Answer | None:
    """The stored answer of `command` on this model text, if the cache holds a valid one."""
    key = _answer_key(command, source, options)
    entry = find_entry(_answer_name(command, key), key)
    try:
        return json.loads(entry.read_text(encoding="utf-8")) if entry else None
    except OSError:         # removed since it was verified (lagc cache clear): compute it again
        return None


def store(command: str, source: SourceFile, options: list, answer: Answer) -> None:
    """Write the answer entry (once; a valid one is kept)."""
    key = _answer_key(command, source, options)
    text = json.dumps(answer) + "\n"
    cached_entry(_answer_name(command, key), key, lambda path: path.write_text(text, encoding="utf-8"))


def _answer_name(command: str, key: str) -> str:
    return f"{command}-{key[:20]}.json"


def _answer_key(command: str, source: SourceFile, options: list) -> str:
    fields = json.dumps([ANSWER_FORMAT, package_digest(), command, options, source.name, package_stamps()])
    return hashlib.sha256(f"{fields}\0{source.text}".encode()).hexdigest()


def package_stamps() -> list:
    """Where each package of COMPUTED_WITH is installed, with its `__init__.py`'s size and time."""
    return [_installed(package) for package in COMPUTED_WITH]


def _installed(package: str) -> list:
    """Where `package` is installed, and the size and time of its `__init__.py`: a new version
    rewrites it."""
    spec = importlib.util.find_spec(package)
    origin = spec.origin if spec is not None else None
    if origin is None:
        return [package, None]
    status = os.stat(origin)
    return [origin, status.st_size, status.st_mtime_ns]
