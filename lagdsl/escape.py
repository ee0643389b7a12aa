"""User text into every place it is written: generated code, CSV and the terminal.

Names of parameters and coordinates are identifiers, but much of what a user writes is free
text: descriptions, the written text of an output expression (the column name, which may hold a
comment), the model file's path. That text reaches generated code, CSV headers and the
terminal ONLY through the functions below, one per target context. Each guarantees that the
text cannot end its context early or change what surrounds it:

`c_comment(text)`     the inside of a C block comment `/* ... */`. The result holds no `*/`
                      (nor `/*`, which -Wcomment rejects), no newline, carriage return or other
                      control character, no Unicode format character (bidirectional overrides,
                      which GCC's -Wbidi-chars rejects), no `??` (so no trigraph such as `??/`,
                      a line splice under -std=c99), and does not end in a backslash (another
                      line splice before the comment's next line), nor in `*` (which would
                      close the comment with a `/` after it). Templates put it after a space.
`c_string(text)`      a complete C99 string literal `"..."` denoting the UTF-8 bytes of the text.
                      Printable ASCII stays as written, except `\\`, `"` and a `?` after a `?`
                      (escaped: no trigraph can form); every other byte, including each byte of
                      a non-ASCII character, is a three-digit octal escape, which ends after
                      three digits and so cannot swallow a following character (as a hex escape
                      would). The literal is clean under `-std=c99 -pedantic`.
`py_string(text)`     a complete Python string literal on one line: Python's `repr`, which
                      escapes quotes, backslashes and every non-printable character, so that
                      `ast.literal_eval(py_string(text)) == text`.
`py_docstring(text)`  the inside of a `\"\"\"...\"\"\"` docstring: backslashes and double quotes
                      are escaped (so no `\"\"\"` ends the docstring, no `\\u` starts an escape)
                      and every non-printable character becomes an escape; the docstring's value
                      is the text itself.
`csv_field(text)`     one field of a CSV record (RFC 4180): in double quotes, with the quotes
                      doubled, when it holds a comma, a double quote, CR or LF; as is otherwise.
`visible(text)`       text for the terminal: control characters (except tab), Unicode format
                      characters and line or paragraph separators become `\\x1b`, `\\u202e`, ...,
                      so that a description cannot move the cursor, recolour the terminal or
                      reorder what is shown.

Escapes are written as in Python: `\\xNN`, `\\uNNNN`, `\\UNNNNNNNN`.
"""
from __future__ import annotations

import re
import unicodedata

# Characters never written as themselves: control (Cc), format (Cf: bidirectional overrides,
# zero-width characters), surrogate (Cs), private-use (Co) and unassigned (Cn) code points, and
# the line and paragraph separators (Zl, Zp).
_HIDDEN_CATEGORIES = frozenset({"Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp"})
_C_STRING_PLAIN = frozenset(range(0x20, 0x7F)) - {ord("\\"), ord('"'), ord("?")}


def _is_hidden(character: str) -> bool:
    return unicodedata.category(character) in _HIDDEN_CATEGORIES


def _escape(character: str) -> str:
    code = ord(character)
    if code < 0x100:
        return f"\\x{code:02x}"
    return f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}"


def _show_hidden(text: str, keep: str = "") -> str:
    return "".join(_escape(c) if _is_hidden(c) and c not in keep else c for c in text)


def c_comment(text: str) -> str:
    """`text` made safe for the inside of a C block comment (see the module docstring)."""
    text = _show_hidden(text)
    text = re.sub(r"(?<=\*)(?=/)|(?<=/)(?=\*)", " ", text)      # */ -> * /, /* -> / *
    text = re.sub(r"(?<=\?)(?=\?)", "\\\\", text)                # ?? -> ?\?
    text = re.sub(r"\\(\s*)$", r"\\x5c\1", text)                 # no line splice at the end
    return re.sub(r"\*$", "* ", text)                             # nor */ with a closing /


def c_string(text: str) -> str:
    """A C99 string literal for `text` (see the module docstring)."""
    pieces = []
    previous = 0
    for byte in text.encode("utf-8", "surrogatepass"):
        if byte in _C_STRING_PLAIN:
            pieces.append(chr(byte))
        elif byte in (ord("\\"), ord('"')):
            pieces.append("\\" + chr(byte))
        elif byte == ord("?"):
            pieces.append("\\?" if previous == byte else "?")
        else:
            pieces.append(f"\\{byte:03o}")
        previous = byte
    return '"' + "".join(pieces) + '"'


def py_string(text: str) -> str:
    """A Python string literal for `text` (see the module docstring)."""
    return repr(str(text))


def py_docstring(text: str) -> str:
    """`text` made safe for the inside of a triple-quoted Python docstring."""
    return "".join(_escape(c) if not (c.isprintable() or c == " ") else
                   "\\" + c if c in '\\"' else c for c in text)


def csv_field(text: str) -> str:
    """`text` as one CSV field (RFC 4180, see the module docstring)."""
    if any(c in text for c in ',"\r\n'):
        return '"' + text.replace('"', '""') + '"'
    return text


def visible(text: str) -> str:
    """`text` for the terminal, control and format characters shown as escapes."""
    return _show_hidden(text, keep="\t")
