"""Kernel -> source text. Both backends print the same `kernel.Kernel`."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING

from .. import escape

if TYPE_CHECKING:
    import jinja2


@dataclass(frozen=True)
class GeneratedSource:
    language: str           # "c" or "numpy"
    text: str
    suggested_name: str     # file name stem, e.g. "DoublePendulum_chaos"


@lru_cache(maxsize=1)
def template_environment() -> jinja2.Environment:
    """Strict templates: a missing variable is an error, never an empty string.

    User text (paths, column names, descriptions, names) is written only through the filters
    `c_comment`, `c_string`, `py_string` and `py_docstring` (lagdsl/escape.py), one per context;
    tests/codegen/test_escaping.py checks that every template does so. (jinja2 is imported here:
    loading a model, or running its stored code, renders nothing.) The templates' compiled code
    is kept in the build cache (trusted as the builds are): compiling them costs a tenth of a
    second a process.
    """
    import jinja2

    from ..run.cache import helper_directory
    directory = helper_directory("jinja2")
    environment = jinja2.Environment(
        loader=jinja2.PackageLoader("lagdsl.codegen", "templates"),
        undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True,
        keep_trailing_newline=True, autoescape=False,
        bytecode_cache=_best_effort_cache(jinja2, directory) if directory is not None else None)
    environment.filters.update(ESCAPE_FILTERS)
    return environment


def _best_effort_cache(jinja2, directory):
    """jinja2's bytecode cache in `directory`, where a failed write (a full disk, `ulimit -f`) only
    leaves the template uncached: the command's own output then meets the limit and says so."""

    class BestEffort(jinja2.FileSystemBytecodeCache):
        def dump_bytecode(self, bucket) -> None:
            try:
                super().dump_bytecode(bucket)       # removes its partial file before raising
            except OSError:
                pass

    return BestEffort(str(directory))


ESCAPE_FILTERS = {"c_comment": escape.c_comment, "c_string": escape.c_string,
                  "py_string": escape.py_string, "py_docstring": escape.py_docstring}
