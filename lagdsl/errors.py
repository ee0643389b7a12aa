"""The three kinds of failure, kept apart.

- `LagError`: the model is wrong. It carries one or more located diagnostics and is rendered
  as `file:line:column: error: message`, the source line and a caret. The command line prints
  it and exits 1, never with a traceback. A diagnostic with no place in a file (a command-line
  option, a value given to simulate()) begins as every other message of lagc does, `lagc: error:`
  (`lagc: note:`), as a compiler's driver names itself (`gcc: error: ...`).
- `SimulationError`: the numbers failed (singular mass matrix, step-size collapse, NaN, the
  step limit). It names the time, the state and a remedy, and keeps the results computed so
  far. `SimulationInterrupted` is the same for a run stopped by Ctrl-C.
- `AnalysisError`: the numbers of a linear analysis failed (no equilibrium near the guess, a
  mass matrix singular at the point). It names the state it reached and a remedy.
- `InternalError`: a bug in lagdsl. It keeps its traceback and asks to be reported.
"""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from typing import Any

from .escape import visible
from .source import Span

PREFIX = "lagc: "        # how a message that is not about a place in a model file begins


@dataclass(frozen=True)
class Setting:
    """Where a value given outside the model file came from: a `lagc run` option such as
    "--rtol" or "--integrator gauss" (the simulate() arguments of the same names)."""

    option: str


@dataclass(frozen=True)
class Diagnostic:
    message: str
    span: Span | Setting | None
    severity: str = "error"         # or "note": something worth knowing, not a mistake

    def render(self) -> str:
        """The diagnostic for the terminal: control characters of the file's name, the message
        and the source line are shown as escapes (`\\x1b`), the caret under them."""
        message = "\n".join(visible(line) for line in self.message.split("\n"))
        if self.span is None:
            return f"{PREFIX}{self.severity}: {message}"
        if isinstance(self.span, Setting):
            return f"{PREFIX}{self.severity}: {visible(self.span.option)}: {message}"
        span = self.span
        line = span.source.line(span.line)
        before = line[:span.column - 1]
        width = max(1, min(span.end - span.start, len(line) - span.column + 1))
        marked = visible(line[span.column - 1:span.column - 1 + width])
        indent = "".join(c if c == "\t" else " " for c in visible(before))   # tabs stay aligned
        caret = indent + " " * (span.column - 1 - len(before)) + "^" + "~" * (len(marked) - 1)
        return (f"{visible(span.source.name)}:{span.line}:{span.column}: {self.severity}: {message}\n"
                f"{visible(line)}\n{caret}")


class LagError(Exception):
    """One or more errors in a model, each with its location."""

    def __init__(self, message: str, span: Span | Setting | None = None):
        self.diagnostics: tuple[Diagnostic, ...] = (Diagnostic(message, span),)
        super().__init__(message)

    @classmethod
    def combine(cls, errors: list["LagError"]) -> "LagError":
        diagnostics = tuple(d for e in errors for d in e.diagnostics)
        # Errors without diagnostics are follow-ons of one reported elsewhere (a poisoned name).
        combined = cls(diagnostics[0].message, diagnostics[0].span) if diagnostics else cls("follow-on error")
        combined.diagnostics = diagnostics
        return combined

    def render(self) -> str:
        return "\n".join(d.render() for d in self.diagnostics)

    def __str__(self) -> str:
        return self.render()


class InputError(LagError, ValueError):
    """A value given outside the model file that does not fit what it sets (a unit of another
    dimension, no number): a LagError for lagc, a ValueError for Python callers."""


class ErrorCollector:
    """Gathers independent errors so that one run reports all of them."""

    def __init__(self) -> None:
        self.errors: list[LagError] = []

    def attempt(self, action, *args, **kwargs) -> Any:
        """Run `action`; on a LagError remember it and return None."""
        try:
            return action(*args, **kwargs)
        except LagError as error:
            self.errors.append(error)
            return None

    def raise_if_any(self) -> None:
        if self.errors:
            raise LagError.combine(self.errors)


class SimulationError(Exception):
    """The integration failed; `partial` holds what was computed before the failure, `status`
    the run's status code (abi.STATUSES), 0 where no run ended with one, `forecast` the steps
    the work forecast said the run would take when it stopped it (integrators/forecast.py)."""

    def __init__(self, message: str, time: float, state: dict[str, float], remedy: str,
                 partial: Any = None, status: int = 0, forecast: float = math.nan):
        self.message, self.time, self.state, self.remedy = message, time, state, remedy
        self.partial, self.status, self.forecast = partial, status, forecast
        super().__init__(self.render())

    def render(self) -> str:
        state = ", ".join(f"{name} = {value:.17g}" for name, value in self.state.items())
        return (f"simulation failed at t = {self.time:.17g}: {self.message}\n"
                f"  state: {state}\n  remedy: {self.remedy}")


class SimulationInterrupted(SimulationError):
    """The run was stopped by Ctrl-C; `partial` holds the rows computed until then."""

    def render(self) -> str:
        return f"interrupted at t = {self.time:.17g}"


class AnalysisError(Exception):
    """An equilibrium or linearization failed on the numbers: what failed, the state it was at
    (the last iterate of a search), and a remedy."""

    def __init__(self, message: str, state: dict[str, float], remedy: str):
        self.message, self.state, self.remedy = message, state, remedy
        super().__init__(self.render())

    def render(self) -> str:
        state = ", ".join(f"{name} = {value:.17g}" for name, value in self.state.items())
        return f"analysis failed: {self.message}\n  state: {state}\n  remedy: {self.remedy}"


class LagWarning(UserWarning):
    """A setting lagdsl changed or doubts, e.g. an rtol below what double precision resolves."""


class InternalError(Exception):
    """A bug in lagdsl, not in the model."""

    def __init__(self, message: str):
        super().__init__(f"internal error in lagdsl, please report: {message}")


def suggest(name: str, candidates) -> str:
    """"; did you mean 'x'?" for the closest candidate within a few typing mistakes, else ""."""
    scored = []
    for candidate in dict.fromkeys(candidates):
        distance = _edit_distance(name, candidate)
        if candidate != name and distance <= max(1, len(name) // 3) and distance < len(name):
            prefix = len(_common_prefix(name, candidate))
            ratio = difflib.SequenceMatcher(None, name, candidate).ratio()
            scored.append((distance, -prefix, -ratio, candidate))
    return f"; did you mean '{min(scored)[3]}'?" if scored else ""


def _common_prefix(a: str, b: str) -> str:
    return a[:next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))]


def _edit_distance(a: str, b: str) -> int:
    """Insertions, deletions, substitutions and swaps of neighbours ("lenght" -> "length" is 1)."""
    if abs(len(a) - len(b)) > 3:
        return abs(len(a) - len(b))
    previous, current = None, list(range(len(b) + 1))
    for i in range(1, len(a) + 1):
        before, previous, current = previous, current, [i] + [0] * len(b)
        for j in range(1, len(b) + 1):
            current[j] = min(previous[j] + 1, current[j - 1] + 1, previous[j - 1] + (a[i - 1] != b[j - 1]))
            if i > 1 and j > 1 and a[i - 1] == b[j - 2] and a[i - 2] == b[j - 1]:
                current[j] = min(current[j], before[j - 2] + 1)
    return current[len(b)]
