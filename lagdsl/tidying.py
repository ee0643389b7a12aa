"""Cheap trigonometric tidying of small expressions, for display (`lagc eom`).

Every step is polynomial in the size of the expanded form, never sympy's simplify or trigsimp
(trigsimp factors polynomials, which costs seconds per expression on a 12-link chain):

    expand
    -> sin(x)² + cos(x)² = 1 among the terms (`pythagoras`), in three forms: as expanded, and
       with the even powers of sines written in cosines and those of cosines in sines (where
       sin⁴ + 2 sin² cos² + cos⁴ has become 1); the form with the fewest terms is kept
    -> cos a cos b + sin a sin b = cos(a - b) and its kin (`sum_formulas`)
    -> common factors out.

An expression whose expansion would have more than EXPANSION_LIMIT terms, or with numbers out
of the ordinary (1e-320 or x^(4e9) read exactly, which sympy's expansion and factoring would
spend minutes or all memory on), is left as it is.
"""
from __future__ import annotations

import sympy
from sympy import QQ
from sympy.polys.rings import PolyRing

EXPANSION_LIMIT = 2000    # terms of the expanded form; more and an expression is left untidied
NUMBER_LIMIT = 10**100    # numerators and denominators of the numbers tidied (physical constants fit)
EXPONENT_LIMIT = 100      # numerators and denominators of the numeric exponents tidied


def tidy(expr: sympy.Expr) -> sympy.Expr:
    """`expr` tidied as the module docstring says (the same value, written shorter)."""
    return written(reduced(expr))


def reduced(expr: sympy.Expr) -> sympy.Expr:
    """`expr` expanded, with sin(x)² + cos(x)² = 1 applied (the steps before the sum formulas):
    a form in which intermediates are inlined into one another and multiplied out again."""
    if not tidiable(expr):
        return expr
    expansion = Expansion(expr)
    forms = [expansion.polynomial, *(expansion.squares_as(square) for square in (sympy.sin, sympy.cos))]
    return min((expansion.pythagoras(form) for form in forms), key=len).as_expr()


def written(expr: sympy.Expr, state=frozenset()) -> sympy.Expr:
    """A reduced expression written for reading: cos a cos b + sin a sin b = cos(a - b) and its
    kin where a sum of a few terms has two angles; the terms with the same factors of the
    `state` symbols (coordinates, velocities, t) gathered, their coefficients summed
    ((A + B) sin(q)²); then common factors out."""
    if not tidiable(expr):
        return expr
    expr = sum_formulas(expr)
    groups: dict[sympy.Expr, list[sympy.Expr]] = {}
    for term in sympy.Add.make_args(expr):
        varying = sympy.Mul(*(f for f in sympy.Mul.make_args(term) if f.free_symbols & state))
        groups.setdefault(varying, []).append(term / varying)
    return sympy.factor_terms(sympy.Add(*(sympy.factor_terms(sympy.Add(*c)) * k for k, c in groups.items())))


def sum_formulas(expr: sympy.Expr) -> sympy.Expr:
    """The terms of a sum read back through the sum and difference formulas, in pairs:
    k r cos(a) cos(b) ± k r sin(a) sin(b) = k r cos(a ∓ b) and
    k r sin(a) cos(b) ± k r cos(a) sin(b) = k r sin(a ± b) (each pair found from its first
    member by a dictionary lookup: linear in the terms, where fu's TR10i tries every pair)."""
    terms: dict[sympy.Expr, sympy.Expr] = {}
    for term in sympy.Add.make_args(expr):
        coefficient, monomial = term.as_coeff_Mul()
        terms[monomial] = terms.get(monomial, sympy.S.Zero) + coefficient
    changed = True
    while changed:
        changed = False
        for monomial in sorted(terms, key=sympy.default_sort_key):
            if monomial in terms and _combine_pair(terms, monomial):
                changed = True
    return sympy.Add(*(coefficient * monomial for monomial, coefficient in terms.items() if coefficient != 0))


def _combine_pair(terms: dict, monomial: sympy.Expr) -> bool:
    """Replace `monomial` and its partner by one term of the sum formulas, if the partner is there
    with the same coefficient or its negative; True if it did."""
    powers = monomial.as_powers_dict()
    single = [f for f, exponent in powers.items() if exponent == 1 and isinstance(f, (sympy.sin, sympy.cos))]
    for first in single:
        for second in single:
            a, b = first.args[0], second.args[0]
            if a == b or isinstance(first, sympy.sin) and isinstance(second, sympy.sin):
                continue
            if isinstance(first, sympy.cos) and isinstance(second, sympy.cos) and sympy.default_sort_key(a) > \
                    sympy.default_sort_key(b):
                continue                     # cos a cos b: seen once, from the first angle
            rest = monomial / (first * second)
            both_cos = isinstance(first, sympy.cos)
            partner = rest * (sympy.sin(a) * sympy.sin(b) if both_cos else sympy.cos(a) * sympy.sin(b))
            mine, theirs = terms[monomial], terms.get(partner, sympy.S.Zero)
            if partner == monomial or theirs not in (mine, -mine):
                continue
            same = theirs == mine
            combined = rest * (sympy.cos(a - b if same else a + b) if both_cos else sympy.sin(a + b if same else a - b))
            del terms[monomial], terms[partner]
            terms[combined] = terms.get(combined, sympy.S.Zero) + mine
            return True
    return False


def tidiable(expr: sympy.Expr) -> bool:
    """Whether tidying `expr` is cheap: its numbers are ordinary and its expansion is not too long."""
    return ordinary_numbers(expr) and expanded_terms(expr) <= EXPANSION_LIMIT


def ordinary_numbers(expr: sympy.Expr) -> bool:
    """Every rational in `expr` has a numerator and denominator below NUMBER_LIMIT, every numeric
    exponent below EXPONENT_LIMIT (model numbers are exact rationals: 1e-320 is 1/10^320)."""
    for number in expr.atoms(sympy.Rational):
        if abs(number.p) >= NUMBER_LIMIT or number.q >= NUMBER_LIMIT:
            return False
    for power in expr.atoms(sympy.Pow):
        if power.exp.is_Rational and (abs(power.exp.p) > EXPONENT_LIMIT or power.exp.q > EXPONENT_LIMIT):
            return False
    return True


def expanded_terms(expr: sympy.Expr) -> int:
    """An upper bound on the number of terms of sympy.expand(expr) (at its top level), counted up
    to just past EXPANSION_LIMIT (the count of (a + b)^(10^9) is not worth computing)."""
    if expr.is_Add:
        count = sum(expanded_terms(a) for a in expr.args)
    elif expr.is_Mul:
        count = 1
        for factor in expr.args:
            count = min(count * expanded_terms(factor), EXPANSION_LIMIT + 1)
    elif expr.is_Pow and expr.exp.is_Integer:     # expand multiplies out 1/(a + b)^n too
        base, count = expanded_terms(expr.base), 1
        for _ in range(min(abs(int(expr.exp)), EXPANSION_LIMIT + 1) if base > 1 else 0):
            count = min(count * base, EXPANSION_LIMIT + 1)
    else:
        count = 1
    return min(count, EXPANSION_LIMIT + 1)


class Expansion:
    """`expr` multiplied out as a polynomial over QQ in its generators: its symbols, the functions
    it applies (sin(x) and cos(x) always in pairs), reciprocals and roots (x^(-1), x^(1/2)), and
    numbers that are not rational (pi). Arithmetic on sympy's sparse polynomials (dicts from
    exponent tuples to rationals) is many times faster than sympy.expand on expression trees."""

    def __init__(self, expr: sympy.Expr):
        found: dict[sympy.Expr, None] = {}
        self._collect(expr, found, set())
        for generator in list(found):
            if isinstance(generator, (sympy.sin, sympy.cos)):
                found[sympy.sin(generator.args[0])] = found[sympy.cos(generator.args[0])] = None
        generators = sorted(found, key=sympy.default_sort_key)
        self.ring = PolyRing(generators or [sympy.Dummy()], QQ)
        index = {generator: k for k, generator in enumerate(generators)}
        self.angles = [(index[g], index[sympy.cos(g.args[0])]) for g in generators if isinstance(g, sympy.sin)]
        self.polynomial = self._element(expr, {})

    @staticmethod
    def _parts(expr: sympy.Expr) -> tuple[sympy.Expr | None, int]:
        """(generator, power) of a node that is one (x^(-3) is (x^(-1), 3)), else (None, 0)."""
        if expr.is_Rational or expr.is_Add or expr.is_Mul or expr.is_Pow and expr.exp.is_Integer and expr.exp > 0:
            return None, 0
        if expr.is_Pow and expr.exp.is_Rational:
            sign = 1 if expr.exp > 0 else -1
            return expr.base ** sympy.Rational(sign, expr.exp.q), abs(expr.exp.p)
        return expr, 1

    def _collect(self, expr: sympy.Expr, found: dict, seen: set) -> None:
        if expr in seen:
            return
        seen.add(expr)
        generator, _ = self._parts(expr)
        if generator is not None:
            found[generator] = None
        elif not expr.is_Rational:
            for argument in (expr.args if not expr.is_Pow else (expr.base,)):
                self._collect(argument, found, seen)

    def _element(self, expr: sympy.Expr, memo: dict):
        if expr not in memo:
            generator, power = self._parts(expr)
            if generator is not None:
                memo[expr] = self.ring(generator) ** power
            elif expr.is_Rational:
                memo[expr] = self.ring(expr)
            elif expr.is_Add:
                memo[expr] = self.ring.add(*(self._element(a, memo) for a in expr.args))
            elif expr.is_Mul:
                product = self.ring.one
                for factor in expr.args:
                    product *= self._element(factor, memo)
                memo[expr] = product
            else:
                memo[expr] = self._element(expr.base, memo) ** int(expr.exp)
        return memo[expr]

    def squares_as(self, square):
        """The polynomial with each even power of square(x) written in the other function,
        square(x)^(2k) = (1 - other(x)²)^k. In this form a sum that is 0 by sin² + cos² = 1
        (sin⁴ + 2 sin² cos² + cos⁴ - 1) has cancelled, and pythagoras shortens what is left."""
        polynomial = self.polynomial
        pairs = [(s, c) if square is sympy.sin else (c, s) for s, c in self.angles]
        pairs = [(written, other) for written, other in pairs
                 if any(exponents[written] >= 2 for exponents in polynomial.itermonoms())]
        if not pairs:
            return polynomial
        complements = {}
        result = self.ring.zero
        for exponents, coefficient in polynomial.items():
            kept = list(exponents)
            term = self.ring({(0,) * self.ring.ngens: coefficient})
            for written, other in pairs:
                halves, kept[written] = divmod(kept[written], 2)
                if halves:
                    if (other, halves) not in complements:
                        complements[other, halves] = (1 - self.ring.gens[other] ** 2) ** halves
                    term *= complements[other, halves]
            result += term.mul_monom(tuple(kept))
        return result

    def pythagoras(self, polynomial):
        """The polynomial with fewer terms by sin(x)² + cos(x)² = 1, applied until nothing changes.

        For each monomial r and angle x, the terms a·r + b·r sin(x)² + c·r cos(x)² are one
        combination with one relation among its members, so one of the three can always be
        dropped: (a + b)·r + (c - b)·r cos², (a + c)·r + (b - c)·r sin², or
        (b + a)·r sin² + (c + a)·r cos². The rewriting that leaves the fewest terms is taken when
        it leaves fewer than before: r sin² + r cos² -> r, r - r sin² -> r cos², and, step by
        step, sin⁴ + 2 sin² cos² + cos⁴ -> sin² + cos² -> 1. Each rewriting removes a term, so the
        loop ends.
        """
        terms = dict(polynomial.items())
        changed = bool(self.angles)
        while changed:
            changed = False
            for monomial in sorted(terms):
                for s, c in self.angles:
                    # a combination is found from its member with sin² or cos²: r itself has neither
                    for k in (s, c):
                        if monomial[k] >= 2 and monomial in terms:
                            changed |= _reduce(terms, _shifted(monomial, k, -2), s, c)
        return self.ring.from_dict(terms)


def _shifted(monomial: tuple, index: int, by: int) -> tuple:
    return monomial[:index] + (monomial[index] + by,) + monomial[index + 1:]


def _reduce(terms: dict, base: tuple, s: int, c: int) -> bool:
    """Rewrite a·r + b·r sin(x)² + c·r cos(x)² (r = base) with fewer terms, if one of the three forms
    of `pythagoras` has fewer; True if it did."""
    members = (base, _shifted(base, s, 2), _shifted(base, c, 2))
    plain, sine, cosine = (terms.get(member, 0) for member in members)
    before = sum(value != 0 for value in (plain, sine, cosine))
    if before < 2:
        return False
    forms = ((plain + sine, 0, cosine - sine), (plain + cosine, sine - cosine, 0), (0, sine + plain, cosine + plain))
    best = min(forms, key=lambda form: sum(value != 0 for value in form))
    if sum(value != 0 for value in best) >= before:
        return False
    for member, value in zip(members, best):
        if value != 0:
            terms[member] = value
        else:
            terms.pop(member, None)
    return True
