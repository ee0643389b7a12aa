"""User text reaches generated code only inside comments and string literals.

The property: for a fixed small model, generating code with a benign text and with an arbitrary
hostile one (holding `*/`, `\"\"\"`, backslashes, newlines, `??/` trigraphs, control and
bidirectional characters) gives the same tokens once comments and string literals are removed,
for C (a small tokenizer that applies the translation phases a C99 compiler does: trigraphs,
line splices) and for Python (`tokenize`). The text travels as a model file's path, as a
description, and as a comment inside an output expression (the column's written text). A few
hostile cases are compiled strictly and run; the reported exploits must not execute.
"""
from __future__ import annotations

import ast
import dataclasses
import io
import re
import tokenize
import unicodedata
from functools import lru_cache
from pathlib import Path

import jinja2
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import lagdsl.api
from lagdsl import escape
from lagdsl.cli import main as lagc
from lagdsl.codegen import ESCAPE_FILTERS, template_environment
from lagdsl.codegen.c import render_c
from lagdsl.codegen.numpy import render_numpy
from lagdsl.pipeline import generate
from lagdsl.source import SourceFile
from tests.conftest import compiled, examples, model_file
from tests.run.c_harness import STRICT_FLAGS, find_cc

MODEL = """model Spring {description}
  parameter k = 1.0 [1/s^2] {description};
  coordinate x(start = 1) [kg^(1/2)*m] {description};
  T = der(x)^2/2;
  U = k*x^2/2;
  scene s {description}
    time(stop = 0.1, interval = 0.05);
    integrator rk4(step = 0.01);
    output x + /* {comment} */ 0, energy;
  end s;
end Spring;
"""
HOSTILE_PIECES = ["*/", "/*", "*", "/", '"""', "'''", '"', "'", "\\", "\\\\", "\n", "\r", "\r\n",
                  "??/", "??=", "???", "\x1b[31m", "\x07", "\x7f", "\u202e", "\u2028", "\x0c", "\t",
                  "\\u", "\\x", "\\N{", "{{", "}}", "%s", "#", "# coding: latin-1", "$(touch PWNED)",
                  "é", "λ", "😀", "\U0010fffd"]
hostile_text = st.lists(st.one_of(st.sampled_from(HOSTILE_PIECES),
                                  st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\0"),
                                          max_size=8)),
                        max_size=12).map("".join)


# ---- tokens outside comments and literals ---------------------------------------------------
C_TOKEN = re.compile(r"""
    (?P<comment>/\*.*?\*/|//[^\n]*)
  | (?P<string>"(?:\\.|[^"\\\n])*")
  | (?P<char>'(?:\\.|[^'\\\n])+')
  | (?P<space>\s+)
  | (?P<token>[A-Za-z_0-9.]+|[^\s])
""", re.VERBOSE | re.DOTALL)
TRIGRAPHS = {"=": "#", "/": "\\", "'": "^", "(": "[", ")": "]", "!": "|", "<": "{", ">": "}", "-": "~"}


def c_tokens(text: str) -> list[str]:
    """The tokens a C99 compiler sees outside comments; each string literal is one `STRING`."""
    text = re.sub(r"\?\?([=/'()!<>-])", lambda m: TRIGRAPHS[m[1]], text)     # phase 1
    text = re.sub(r"\\[ \t\f\v]*\n", "", text)                                # phase 2 (GCC)
    tokens, position = [], 0
    while position < len(text):
        match = C_TOKEN.match(text, position)
        if match.lastgroup == "token" and match[0] in ('"', "'") or match[0] == "/" and text.startswith("/*", position):
            raise AssertionError(f"unterminated literal or comment at {text[position:position + 60]!r}")
        if match.lastgroup in ("string", "char"):
            tokens.append("STRING")
        elif match.lastgroup == "token":
            tokens.append(match[0])
        position = match.end()
    return tokens


def python_tokens(text: str) -> list[tuple[int, str]]:
    """Python's tokens outside comments; each string literal is one `STRING`."""
    compile(text, "generated.py", "exec")
    return [(t.type, "STRING" if t.type == tokenize.STRING else t.string)
            for t in tokenize.generate_tokens(io.StringIO(text).readline)
            if t.type not in (tokenize.COMMENT, tokenize.NL)]


TOKENS = {"c": c_tokens, "numpy": python_tokens}


# ---- the generated code, with user text in every place it can go ----------------------------
@lru_cache(maxsize=1)
def spring() -> lagdsl.api.Model:
    return lagdsl.api.Model(SourceFile("spring.lag", MODEL.format(description="", comment="")))


def rendered(backend: str, text: str) -> str:
    """The spring's code with `text` as every user-written string a kernel carries."""
    model = spring()
    kernel = generate(model.equations, model.plan(), backend, "spring.lag")[0]
    kernel = dataclasses.replace(kernel, columns=(text, f"{text}, energy"), model_name=text, scene_name=text,
                                 parameters=tuple((text, value) for _, value in kernel.parameters),
                                 coordinates=tuple(text for _ in kernel.coordinates))
    render = {"c": render_c, "numpy": render_numpy}[backend]
    return render(kernel, text).text


@pytest.mark.parametrize("backend", ["c", pytest.param("numpy", marks=pytest.mark.slow)])
@settings(max_examples=examples(60), deadline=None)
@given(text=hostile_text)
@example(text='x + /* """+str(__import__(\'os\').system(\'touch PWNED\'))+""" */ 0')
@example(text='d*/ int system(const char *); __attribute__((constructor)) static void f(void) '
              '{ system("touch PWNED"); } /*x/m.lag')
@example(text='e"""+str(__import__("os").system("touch PWNED"))+"""/m.lag')
@example(text="C:\\users\\m.lag")
@example(text="dir\\")
def test_user_text_never_changes_the_code_around_it(backend, text):
    assert TOKENS[backend](rendered(backend, text)) == TOKENS[backend](rendered(backend, "benign"))


def write_model(directory: Path, description: str, comment: str) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "m.lag"
    path.write_text(MODEL.format(description=f'"{description}"', comment=comment), encoding="utf-8")
    return path


def directory_name(text: str) -> str:
    """`text` as one file-name component: no '/', no NUL, at most 200 bytes, not . or .."""
    name = text.replace("/", "\\").replace("\0", "")[:50]
    while len(name.encode("utf-8", "surrogateescape")) > 200:
        name = name[:-1]
    return name if name not in ("", ".", "..") else "_" + name


@pytest.mark.parametrize("backend", ["c", "numpy"])
@settings(max_examples=examples(12), deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=hostile_text)
def test_hostile_paths_descriptions_and_comments_through_the_whole_pipeline(tmp_path, backend, text):
    # The grammar bounds each context: a description holds no '"' or newline, a comment no '*/'.
    description = re.sub(r'["\n\r]', "", text)
    comment = text
    while "*/" in comment:
        comment = comment.replace("*/", "*")
    hostile = lagdsl.load(write_model(tmp_path / directory_name(text), description, comment))
    benign = lagdsl.load(write_model(tmp_path / "benign", "", ""))
    assert TOKENS[backend](hostile.emit(backend).text) == TOKENS[backend](benign.emit(backend).text)


# ---- strict compilation and the reported exploits -------------------------------------------
EXPLOIT_COMMENT = ' """+str(__import__(\'os\').system(\'touch PWNED\'))+""" '
EXPLOIT_C_DIRECTORY = ('d*/ int system(const char *); __attribute__((constructor)) static void f(void) '
                       '{ system("touch PWNED"); } /*x')
EXPLOIT_PYTHON_DIRECTORY = 'e"""+str(__import__("os").system("touch PWNED"))+"""'
HOSTILE_CASES = [  # (directory, comment in the output expression, description)
    (EXPLOIT_C_DIRECTORY, EXPLOIT_COMMENT, "\x1b[2J\u202e"),
    (EXPLOIT_PYTHON_DIRECTORY, " metres ??/", "a \\"),
    ("C:\\users", "??/", "ends in a backslash \\"),
    ("dir*", "*", ""),
]


@pytest.mark.parametrize("directory, comment, description", HOSTILE_CASES[:3])
def test_hostile_generated_c_compiles_strictly(tmp_path, directory, comment, description):
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    source = tmp_path / "m.c"
    source.write_text(lagdsl.load(write_model(tmp_path / directory, description, comment)).emit("c").text,
                      encoding="utf-8")
    done = compiled([cc, *STRICT_FLAGS, "-fsyntax-only", str(source)])
    assert done.returncode == 0, done.stderr


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("directory, comment, description", HOSTILE_CASES)
def test_lagc_run_of_a_hostile_model_runs_and_executes_nothing(tmp_path, monkeypatch, capsys, backend,
                                                               directory, comment, description):
    if backend == "c" and find_cc() is None:
        pytest.skip("no C compiler")
    # At one path in every run, so that the suite's build cache holds its code: loading the
    # library (where an injected constructor would run) and the run happen all the same.
    path = model_file(MODEL.format(description=f'"{description}"', comment=comment), f"{directory}/m")
    monkeypatch.chdir(tmp_path)
    assert lagc(["run", str(path), "--backend", backend]) == 0
    assert not (tmp_path / "PWNED").exists()
    column = " ".join(f"x + /* {comment} */ 0".split())        # the written text, as the CSV header shows it
    assert capsys.readouterr().out.splitlines()[0] == f"t,{escape.csv_field(column)},energy"


# ---- every template writes user text through an escape --------------------------------------
# The context variables that hold user text, and the loop variables bound to their items.
USER_TEXT = {"title", "source_name", "model", "scene", "stem", "parameter_list", "option_list",
             "integrator", "columns", "csv_columns", "invariant_names", "constraints",
             "parameter_names", "coordinates", "parameters"}
NUMERIC_FILTERS = {"length", "float"}


def unescaped(node: jinja2.nodes.Node, tainted: set[str]) -> set[str]:
    """The user-text variables that `node` writes without an escape filter around them."""
    if isinstance(node, jinja2.nodes.Filter) and (node.name in ESCAPE_FILTERS or node.name in NUMERIC_FILTERS):
        return set()
    if isinstance(node, jinja2.nodes.Filter) and node.name == "map" and \
            isinstance(node.args[0], jinja2.nodes.Const) and node.args[0].value in ESCAPE_FILTERS:
        return set()                                        # items | map("c_string")
    if isinstance(node, jinja2.nodes.Name):
        return {node.name} & tainted
    children = [node.expr1, node.expr2] if isinstance(node, jinja2.nodes.CondExpr) else node.iter_child_nodes()
    return set().union(*(unescaped(child, tainted) for child in children if child is not None))


@pytest.mark.parametrize("template", ["c/model.c.j2", "numpy/model.py.j2"])
def test_templates_write_user_text_only_through_escape_filters(template):
    environment = template_environment()
    tree = environment.parse(environment.loader.get_source(environment, template)[0])
    tainted = set(USER_TEXT)
    for loop in tree.find_all(jinja2.nodes.For):
        if {n.name for n in loop.iter.find_all(jinja2.nodes.Name)} & tainted:
            tainted |= {n.name for n in loop.target.find_all(jinja2.nodes.Name)}
    for output in tree.find_all(jinja2.nodes.Output):
        for node in output.nodes:
            raw = unescaped(node, tainted)
            assert not raw, f"{template}:{node.lineno}: {sorted(raw)} written without an escape"


# ---- the escapes themselves -----------------------------------------------------------------
@given(text=hostile_text)
def test_python_literals_and_docstrings_keep_the_text(text):
    assert ast.literal_eval(escape.py_string(text)) == text
    assert ast.literal_eval('"""' + escape.py_docstring(text) + '"""') == text


@given(text=hostile_text)
def test_c_comment_is_one_line_that_cannot_close_or_splice(text):
    comment = escape.c_comment(text)
    assert "*/" not in comment and "/*" not in comment and "??" not in comment
    assert not any(unicodedata.category(c) in ("Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp") for c in comment)
    assert not comment.endswith(("*", "\\"))
    assert not re.search(r"\\\s*$", comment)


@given(text=hostile_text)
def test_c_string_is_plain_ascii_and_decodes_to_the_utf8_bytes(text):
    literal = escape.c_string(text)
    assert literal.isascii() and literal.isprintable() and "??" not in literal
    body = re.sub(r"\\([0-7]{3}|.)", lambda m: chr(int(m[1], 8)) if len(m[1]) == 3 else m[1], literal[1:-1])
    assert '"' not in re.sub(r'\\.', "", literal[1:-1])
    assert body.encode("latin-1") == text.encode("utf-8")


def test_csv_fields_are_quoted_only_where_needed():
    assert escape.csv_field("theta1") == "theta1"
    assert escape.csv_field("max(x, 0)") == '"max(x, 0)"'
    assert escape.csv_field('a "b"') == '"a ""b"""'
    assert escape.csv_field("a\nb") == '"a\nb"'


def test_visible_shows_control_and_bidirectional_characters():
    assert escape.visible("red \x1b[31m\u202e\ttab") == "red \\x1b[31m\\u202e\ttab"
