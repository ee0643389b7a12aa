"""Text -> lark Tree. Syntax errors become LagErrors worded in the language's own terms."""
from __future__ import annotations

from functools import lru_cache
from importlib import resources

import lark
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from .errors import LagError
from .source import SourceFile, Span

KEYWORDS = {
    "MODEL": "model", "END": "end", "PARAMETER": "parameter", "COORDINATE": "coordinate",
    "LET": "let", "DISSIPATION": "dissipation", "FORCE": "force", "CONSTRAINT": "constraint",
    "OUTPUT": "output", "SCENE": "scene", "TIME": "time", "INTEGRATOR": "integrator",
    "SET": "set", "IN": "in",
}
TOKEN_WORDS = {
    **{name: f"'{word}'" for name, word in KEYWORDS.items()},
    "ENERGY": "'T', 'U' or 'L'", "NAME": "a name", "NUMBER": "a number",
    "STRING": 'a description in double quotes', "UNIT": "a unit such as [kg]",
    "POW": "'^'", "PLUS": "'+'", "MINUS": "'-'", "STAR": "'*'", "SLASH": "'/'", "EQ": "'='",
    "SEMI": "';'", "COLON": "':'", "COMMA": "','", "LPAR": "'('", "RPAR": "')'", "LSQB": "'['",
    "RSQB": "']'", "LBRACE": "'{'", "RBRACE": "'}'", "$END": "the end of the file",
}
DECLARATION_STARTS = {"PARAMETER", "COORDINATE", "LET", "ENERGY", "DISSIPATION", "FORCE",
                      "CONSTRAINT", "OUTPUT", "SCENE"}
EXPRESSION_STARTS = {"NAME", "NUMBER", "LPAR", "LBRACE", "MINUS", "PLUS"}
OPERATORS = {"PLUS", "MINUS", "STAR", "SLASH", "POW"}


@lru_cache(maxsize=1)
def _lark() -> lark.Lark:
    grammar = resources.files("lagdsl").joinpath("grammar.lark").read_text(encoding="utf-8")
    return lark.Lark(grammar, parser="lalr", lexer="contextual", propagate_positions=True,
                     maybe_placeholders=False)


def parse(source: SourceFile) -> lark.Tree:
    """Parse a whole model file into a concrete syntax tree with positions on every node."""
    try:
        return _lark().parse(source.text)
    except UnexpectedInput as error:
        raise _syntax_error(source, error) from None


def span_of_token(source: SourceFile, token: lark.Token) -> Span:
    return Span(source, token.line, token.column, token.start_pos, token.end_pos)


def span_at(source: SourceFile, offset: int, length: int = 1) -> Span:
    offset = max(0, min(offset, len(source.text)))
    line = source.text.count("\n", 0, offset) + 1
    column = offset - (source.text.rfind("\n", 0, offset) + 1) + 1
    return Span(source, line, column, offset, offset + length)


def _describe(expected: set[str]) -> str:
    expected = {name for name in expected if not name.startswith("__")}
    if len(expected & EXPRESSION_STARTS) >= 4:
        expected = (expected - EXPRESSION_STARTS - OPERATORS) | {"an expression"}
    elif len(expected & OPERATORS) >= 3:
        expected = (expected - OPERATORS) | {"an operator"}
    if len(expected & DECLARATION_STARTS) >= 4:
        expected = (expected - DECLARATION_STARTS) | {"a declaration"}
    words = sorted(TOKEN_WORDS.get(name, name) for name in expected)
    if len(words) > 1:
        return ", ".join(words[:-1]) + " or " + words[-1]
    return words[0] if words else "something else"


def _end_of_previous_token(source: SourceFile, offset: int) -> int:
    """Offset just after the last non-blank character before `offset` (where a ';' is missing)."""
    index = offset
    while index > 0 and source.text[index - 1].isspace():
        index -= 1
    return index


def _syntax_error(source: SourceFile, error: UnexpectedInput) -> LagError:
    if isinstance(error, UnexpectedCharacters):
        char = source.text[error.pos_in_stream]
        if char == "[":
            message = "unexpected '[': an index follows its name without a space (theta[i]); a unit is written after a space ([kg])"
        else:
            message = f"unexpected character '{char}'"
        return LagError(message, span_at(source, error.pos_in_stream))
    if isinstance(error, UnexpectedEOF):
        return LagError(f"unexpected end of file: expected {_describe(set(error.expected))}",
                        span_at(source, len(source.text.rstrip()), 1))
    assert isinstance(error, UnexpectedToken)
    token, expected = error.token, set(error.expected)
    if token.type == "$END":
        return LagError(f"unexpected end of file: expected {_describe(expected)}",
                        span_at(source, len(source.text.rstrip()), 1))
    span = span_of_token(source, token)
    if "NAME" in expected and token.type in KEYWORDS | {"ENERGY": ""}:
        return LagError(f"'{token}' is a reserved word and cannot be used as a name", span)
    if "SEMI" in expected and token.line > _line_of(source, _end_of_previous_token(source, token.start_pos)):
        at = _end_of_previous_token(source, token.start_pos)
        return LagError("expected ';' at the end of the statement", span_at(source, at))
    return LagError(f"expected {_describe(expected)}, found '{token}'", span)


def _line_of(source: SourceFile, offset: int) -> int:
    return source.text.count("\n", 0, offset) + 1
