"""Text -> lark Tree. Syntax errors become LagErrors worded in the language's own terms."""
from __future__ import annotations

import re
from functools import lru_cache
from pathlib import Path

import lark
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from ..errors import LagError
from ..source import SourceFile, Span

KEYWORDS = {
    "MODEL": "model", "END": "end", "PARAMETER": "parameter", "COORDINATE": "coordinate",
    "LET": "let", "DISSIPATION": "dissipation", "FORCE": "force", "CONSTRAINT": "constraint",
    "OUTPUT": "output", "DRAW": "draw", "SCENE": "scene", "TIME": "time", "INTEGRATOR": "integrator",
    "SET": "set", "IN": "in", "STOP": "stop", "WHEN": "when",
}
TOKEN_WORDS = {
    **{name: f"'{word}'" for name, word in KEYWORDS.items()},
    "ENERGY": "'T', 'U' or 'L'", "NAME": "a name", "NUMBER": "a number",
    "STRING": 'a description in double quotes', "UNIT": "a unit such as [kg]",
    "POW": "'^'", "PLUS": "'+'", "MINUS": "'-'", "STAR": "'*'", "SLASH": "'/'", "EQ": "'='",
    "SEMI": "';'", "COLON": "':'", "COMMA": "','",
    "DOT": "'.'", "LESS": "'<'", "GREATER": "'>'", "LPAR": "'('", "RPAR": "')'", "LSQB": "'['",
    "RSQB": "']'", "LBRACE": "'{'", "RBRACE": "'}'", "$END": "the end of the file",
}
DECLARATION_STARTS = {"PARAMETER", "COORDINATE", "LET", "ENERGY", "DISSIPATION", "FORCE",
                      "CONSTRAINT", "OUTPUT", "DRAW", "SCENE"}
EXPRESSION_STARTS = {"NAME", "NUMBER", "LPAR", "LBRACE", "MINUS", "PLUS"}
OPERATORS = {"PLUS", "MINUS", "STAR", "SLASH", "POW"}
CLOSING = {"LPAR": "RPAR", "LSQB": "RSQB", "LBRACE": "RBRACE"}     # opening bracket -> closing
OPENING = {closer: opener for opener, closer in CLOSING.items()}
STATEMENT_LEVEL = DECLARATION_STARTS | {"SEMI", "END", "TIME", "INTEGRATOR", "SET", "STOP", "MODEL"}


@lru_cache(maxsize=1)
def _lark() -> lark.Lark:
    """The parser, its LALR tables kept in the build cache (lark checks the grammar's hash on
    loading them): building them costs about 0.15 s a process. The grammar is read beside this
    file (as known_units.py reads its table): importlib.resources would import zipfile and its
    readers, a sixtieth of a second."""
    from ..run.cache import helper_directory
    grammar = Path(__file__).with_name("grammar.lark").read_text(encoding="utf-8")
    options = {"parser": "lalr", "lexer": "contextual", "propagate_positions": True, "maybe_placeholders": False}
    directory = helper_directory("lark")
    if directory is not None:
        options["cache"] = str(directory / f"grammar-{lark.__version__}.cache")
    try:
        return lark.Lark(grammar, **options)
    except OSError:         # a cache file that cannot be written
        return lark.Lark(grammar, **{**options, "cache": False})


def parse(source: SourceFile) -> lark.Tree:
    """Parse a whole model file into a concrete syntax tree with positions on every node.

    The parse is driven token by token so that, on an error, the parser's state tells exactly
    which tokens it would have accepted there (lark's `expected` sets are coarser).
    """
    interactive = _lark().parse_interactive(source.text)
    try:
        for _ in interactive.iter_parse():
            pass
        return interactive.feed_eof(interactive.lexer_thread.state.last_token)
    except UnexpectedInput as error:
        raise _syntax_error(source, error, _accepted(interactive, error)) from None


def _accepted(interactive, error: UnexpectedInput) -> set[str]:
    """The terminals the parser would accept where it stopped."""
    try:
        return set(interactive.accepts())
    except Exception:                      # the parser state is unusable: fall back on lark's guess
        return set(getattr(error, "expected", None) or getattr(error, "allowed", None) or ())


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


def _syntax_error(source: SourceFile, error: UnexpectedInput, accepts: set[str]) -> LagError:
    text = source.text
    position = error.token.start_pos if isinstance(error, UnexpectedToken) else error.pos_in_stream
    if isinstance(error, UnexpectedToken) and error.token.type == "$END" or isinstance(error, UnexpectedEOF):
        position = len(text)
    if text.startswith("/*", position or 0):
        return LagError("unterminated comment: '/*' has no closing '*/'", span_at(source, position, 2))
    if isinstance(error, UnexpectedCharacters):
        return _unexpected_character(source, position)
    if isinstance(error, UnexpectedEOF) or error.token.type == "$END":
        return _unexpected_end(source, accepts)
    token = error.token
    span = span_of_token(source, token)
    after_space = position > 0 and text[position - 1].isspace()
    if "NAME" in accepts and token.type in KEYWORDS | {"ENERGY": ""}:
        return LagError(f"'{token}' is a reserved word and cannot be used as a name", span)
    if token.type == "LSQB" and "UNIT" in accepts and "LSQB" not in accepts:
        if after_space:
            return LagError("unterminated unit: a unit such as [kg] ends with ']' on the same line",
                            span_at(source, position))
        return LagError("a unit is written after a space ([kg]); an index follows its name without "
                        "a space (theta[i])", span_at(source, position))
    if token.type == "UNIT" and "UNIT" not in accepts:
        name = re.search(r"(?<![\w.])[A-Za-z_]\w*$", text[:position].rstrip())
        if name:
            return LagError(f"'{token}' after a space reads as a unit, and no unit belongs here; an index is "
                            f"written without a space: {name.group()}{token}", span)
        return LagError(f"unexpected '{token}': a unit is only written after the value of a parameter, "
                        "coordinate or output", span)
    bracket = _bracket_error(source, token, accepts)
    if bracket is not None:
        return bracket
    if "SEMI" in accepts and token.line > _line_of(source, _end_of_previous_token(source, token.start_pos)):
        at = _end_of_previous_token(source, token.start_pos)
        return LagError("expected ';' at the end of the statement", span_at(source, at))
    if accepts == {"$END"}:
        return LagError(f"unexpected '{token}' after the end of the model; a file holds one model", span)
    return LagError(f"expected {_describe(accepts)}, found '{token}'", span)


def _unexpected_character(source: SourceFile, position: int) -> LagError:
    char = source.text[position]
    if char == '"':
        return LagError("unterminated description: the closing '\"' is missing on this line",
                        span_at(source, position))
    shown = f"'{char}'" if char.isprintable() else f"U+{ord(char):04X}"
    return LagError(f"unexpected character {shown}", span_at(source, position))


def _unexpected_end(source: SourceFile, accepts: set[str]) -> LagError:
    at = span_at(source, len(source.text.rstrip()), 1)
    tokens = _tokens_before(source, len(source.text))
    opened = _open_brackets(tokens)
    if opened and CLOSING[opened[-1].type] in accepts:
        bracket = opened[-1]
        return LagError(f"unexpected end of file: the '{bracket}' at line {bracket.line}, column "
                        f"{bracket.column} is not closed", at)
    if "END" in accepts:
        blocks = _open_blocks(tokens)
        if blocks:
            kind, name = blocks[-1]
            return LagError(f"unexpected end of file: {kind} '{name}' is not closed; expected 'end {name};'", at)
    return LagError(f"unexpected end of file: expected {_describe(accepts)}", at)


def _tokens_before(source: SourceFile, offset: int) -> list[lark.Token]:
    """The tokens of the text before `offset` (as far as it can be split into tokens)."""
    found = []
    try:
        for token in _lark().lex(source.text[:offset]):
            found.append(token)
    except UnexpectedInput:
        pass
    return found


def _open_brackets(tokens: list[lark.Token]) -> list[lark.Token]:
    stack: list[lark.Token] = []
    for token in tokens:
        if token.type in CLOSING:
            stack.append(token)
        elif token.type in OPENING and stack and stack[-1].type == OPENING[token.type]:
            stack.pop()
        elif token.type == "SEMI":           # a statement never continues past its ';'
            stack.clear()
    return stack


def _open_blocks(tokens: list[lark.Token]) -> list[tuple[str, str]]:
    blocks: list[tuple[str, str]] = []
    for previous, token in zip(tokens, tokens[1:]):
        if previous.type in ("MODEL", "SCENE") and token.type == "NAME":
            blocks.append((str(previous), str(token)))
        elif previous.type == "END" and blocks:
            blocks.pop()
    return blocks


def _bracket_error(source: SourceFile, token: lark.Token, accepts: set[str]) -> LagError | None:
    """Unbalanced (), [] and {}: name the bracket that is left open, or the stray closer."""
    opened = _open_brackets(_tokens_before(source, token.start_pos))
    span = span_of_token(source, token)
    closer = CLOSING[opened[-1].type] if opened else None
    if closer is not None and closer in accepts and token.type not in accepts and (
            token.type in OPENING or token.type in STATEMENT_LEVEL or _starts_line(source, token)):
        bracket = opened[-1]
        return LagError(f"expected {TOKEN_WORDS[closer]} to close the '{bracket}' at line {bracket.line}, "
                        f"column {bracket.column}, found '{token}'", span)
    if token.type in OPENING and token.type not in accepts and not opened:
        return LagError(f"unmatched '{token}': there is no {TOKEN_WORDS[OPENING[token.type]]} for it to close", span)
    return None


def _starts_line(source: SourceFile, token: lark.Token) -> bool:
    """Is `token` the first thing on its line (so probably the start of the next statement)?"""
    return source.text[source.text.rfind("\n", 0, token.start_pos) + 1:token.start_pos].strip() == ""


def _line_of(source: SourceFile, offset: int) -> int:
    return source.text.count("\n", 0, offset) + 1
