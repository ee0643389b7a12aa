"""LaTeX of the equations of motion (`lagc eom --latex`): an aligned environment, one row per
equation, then the named intermediates after `\\text{where}`.

Every name of a model is typeset by one rule, wherever it appears:

- a name that is a Greek letter's is that letter: `theta` -> \\theta, `Omega` -> \\Omega; `eps` and
  `epsilon` are both \\varepsilon, `lam` and `lambda` both \\lambda (in a model that uses both
  spellings for two quantities, the short one is written as a word, \\mathrm{eps});
- a single letter is itself; any other name is upright, as a word: `me` -> \\mathrm{me};
- trailing digits, the part after the first underscore, indices and vector components are
  subscripts, each typeset by the same rule: `theta1` -> \\theta_{1}, `m_rotor` -> m_{\\mathrm{rotor}},
  `x[2]` -> x_{2}, `R[1,2]` -> R_{1,2}, `w.x` -> w_{x};
- a velocity q' is \\dot{q}, an acceleration q'' is \\ddot{q}, and so are der(x) and der(der(x)) of a
  let: `theta1''` -> \\ddot{\\theta}_{1};
- the multiplier of constraint c is \\lambda_{\\mathrm{c}}.

sympy's printer sets parentheses as \\left( \\right), so they stretch with what they hold.
"""
from __future__ import annotations

import re
from collections import Counter

import sympy

GREEK = ("alpha", "beta", "gamma", "delta", "epsilon", "varepsilon", "zeta", "eta", "theta", "vartheta", "iota",
         "kappa", "lambda", "mu", "nu", "xi", "pi", "varpi", "rho", "varrho", "sigma", "varsigma", "tau", "upsilon",
         "phi", "varphi", "chi", "psi", "omega",
         "Gamma", "Delta", "Theta", "Lambda", "Xi", "Pi", "Sigma", "Upsilon", "Phi", "Psi", "Omega")
LETTER_FORMS = {"epsilon": "varepsilon"}                  # one look for the letter, however it is named
ABBREVIATIONS = {"eps": "varepsilon", "lam": "lambda"}

_IDENTIFIER = re.compile(r"(?P<word>[A-Za-z]+)(?P<digits>[0-9]*)(?:_(?P<tail>[A-Za-z0-9_]+))?"
                         r"(?:\[(?P<index>[0-9, ]+)\])?(?:\.(?P<component>[xyz]))?")
_DERIVATIVE = re.compile(r"der\((?P<inner>.*)\)")


def typeset(rows, where) -> str:
    """The aligned environment of `rows` ((label, lhs, rhs) each) and of the `where` list
    ((symbol, definition) each); no line break after the last row."""
    symbols = set().union(*(side.free_symbols for _, lhs, rhs in rows for side in (lhs, rhs)),
                          *({s} | e.free_symbols for s, e in where))
    names = {symbol: latex_name(symbol.name) for symbol in symbols}
    written = Counter(names.values())
    for symbol in symbols:
        if written[names[symbol]] > 1:             # eps and epsilon in one model: two quantities
            names[symbol] = latex_name(symbol.name, abbreviations=False)
    body = [rf"{_latex(lhs, names)} &= {_latex(rhs, names)}" for _, lhs, rhs in rows]
    if where:
        body.append(r"&\text{where}")
        body.extend(rf"{names[s]} &= {_latex(e, names)}" for s, e in where)
    return "\\begin{aligned}\n" + " \\\\\n".join(body) + "\n\\end{aligned}"


def _latex(expr: sympy.Expr, names: dict) -> str:
    return sympy.latex(expr, symbol_names=names)


def latex_name(name: str, abbreviations: bool = True) -> str:
    """The LaTeX of a name as the module docstring says (`abbreviations` False: `eps` and `lam`
    are words, not letters)."""
    dots = len(name) - len(name.rstrip("'"))
    name = name.rstrip("'")
    derivative = _DERIVATIVE.fullmatch(name)
    while derivative:
        dots += 1
        name = derivative.group("inner")
        derivative = _DERIVATIVE.fullmatch(name)
    if name.startswith("λ[") and name.endswith("]"):
        return rf"\lambda_{{\mathrm{{{_escaped(name[2:-1])}}}}}"
    parts = _IDENTIFIER.fullmatch(name)
    if parts is None:                                      # not a name of the language: as written
        return rf"\mathrm{{{_escaped(name)}}}"
    base = _word(parts.group("word"), abbreviations)
    if dots:
        base = rf"\{'d' * dots}ot{{{base}}}"
    subscripts = [_subscript(parts.group(key)) for key in ("digits", "tail", "index", "component")
                  if parts.group(key)]
    return base + (f"_{{{','.join(subscripts)}}}" if subscripts else "")


def _word(word: str, abbreviations: bool = True) -> str:
    word = ABBREVIATIONS.get(word, word) if abbreviations else word
    word = LETTER_FORMS.get(word, word)
    if word in GREEK:
        return "\\" + word
    return word if len(word) == 1 else rf"\mathrm{{{word}}}"


def _subscript(text: str) -> str:
    if text.replace(",", "").replace(" ", "").isdigit():
        return text.replace(" ", "")
    return _word(text) if text.isalpha() else rf"\mathrm{{{_escaped(text)}}}"


def _escaped(text: str) -> str:
    return text.replace("\\", r"\backslash ").replace("_", r"\_").replace("{", r"\{").replace("}", r"\}")
