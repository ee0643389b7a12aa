"""Kernel -> source text. Both backends print the same `kernel.Kernel`."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import jinja2


@dataclass(frozen=True)
class GeneratedSource:
    language: str           # "c" or "numpy"
    text: str
    suggested_name: str     # file name stem, e.g. "DoublePendulum_chaos"


@lru_cache(maxsize=1)
def template_environment() -> jinja2.Environment:
    """Strict templates: a missing variable is an error, never an empty string."""
    return jinja2.Environment(
        loader=jinja2.PackageLoader("lagdsl.codegen", "templates"),
        undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True,
        keep_trailing_newline=True, autoescape=False)
