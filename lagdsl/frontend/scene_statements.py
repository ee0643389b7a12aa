"""The scenes of a model: time grid, integrator, parameter and initial-value overrides, the
output list, a stop condition and draw statements, read with every name of the model in scope.
"""
from __future__ import annotations

from dataclasses import replace

import lark

from .. import ir
from ..errors import ErrorCollector, LagError, suggest
from .functions import OBSERVABLES
from ..integrators import registry
from ..integrators.registry import OPTIONS
from ..settings import DEFAULT_INTEGRATOR, DEFAULT_TIME, check_integrator_name, validate_integrator
from ..source import Span
from . import units
from .units import Dimension
from ..tolerances import check_atol_each, component_input, component_key
from .tree import call_arguments, expressions_of, subtree, subtrees, through, tokens, written
from .values import PoisonedName

TIME = Dimension.of(time=1)


def _words(dimension: Dimension) -> str:
    return "dimensionless" if dimension.dimensionless else f"a {dimension.words()}"


# The statements a scene gives at most once, and their names in messages.
ONCE = {"scene_time": "time(...)", "scene_integrator": "integrator(...)", "scene_stop": "a stop condition"}


class SceneStatements:
    """Scenes: a part of semantics._ModelBuilder, whose state it reads (scope, expr, numbers, dims,
    parameters, coordinates, outputs, draws) and extends (scenes, scene_spans), and whose
    helpers it calls (modifiers, coordinate_member, target_name, output_scope, draw, span, description)."""

    def scene(self, node):
        names = tokens(node, "NAME")
        name, end_name = names[0], names[-1]
        errors = ErrorCollector()
        if str(end_name) != str(name):
            errors.errors.append(LagError(f"'end {end_name}' does not match scene '{name}'; expected 'end {name};'",
                                          self.span(end_name)))
        if str(name) in self.scene_spans:
            errors.errors.append(LagError(f"scene '{name}' is declared twice (first at line "
                                          f"{self.scene_spans[str(name)].line})", self.span(name)))
        else:
            self.scene_spans[str(name)] = self.span(name)
        parts = self._scene_statements(node, str(name), errors)
        errors.raise_if_any()
        self.scenes.append(ir.Scene(str(name), self.description(node), parts["scene_time"] or DEFAULT_TIME,
                                    parts["scene_integrator"] or DEFAULT_INTEGRATOR, tuple(parts["parameters"]),
                                    tuple(parts["initial"]), tuple(parts["outputs"]), self.span(name),
                                    parts["scene_stop"], tuple(parts["draws"])))

    def _scene_statements(self, node, name: str, errors: ErrorCollector) -> dict:
        """What the statements of a scene give, each statement's errors collected in `errors`."""
        parts = {"scene_time": None, "scene_integrator": None, "scene_stop": None,
                 "parameters": [], "initial": [], "outputs": [], "draws": []}
        given: dict[str, Span] = {}
        for statement in subtrees(node):
            if statement.data in ONCE:
                word = ONCE[statement.data]
                if word in given:
                    errors.errors.append(LagError(f"the scene gives {word} twice (first at line "
                                                  f"{given[word].line})", self.span(statement)))
                    continue
                given[word] = self.span(statement)
                parts[statement.data] = errors.attempt(getattr(self, statement.data), statement)
            elif statement.data == "scene_set":
                override = errors.attempt(self.scene_set, statement)
                if override is not None:
                    parts["parameters" if isinstance(override, ir.ParameterOverride) else "initial"].append(override)
            elif statement.data == "scene_output":
                for item in subtrees(statement):
                    request = errors.attempt(self.output_request, item, name)
                    twice = next((o for o in parts["outputs"] if request and o.column == request.column), None)
                    if twice is not None:
                        errors.errors.append(LagError(f"'{request.column}' is already in the output list",
                                                      request.span))
                    elif request is not None:
                        parts["outputs"].append(request)
            elif statement.data == "draw":          # after the model's own (draw_statements.py)
                drawn = errors.attempt(self.draw, statement, self.draws + parts["draws"])
                parts["draws"] += [drawn] if drawn is not None else []
        return parts

    def scene_time(self, node) -> ir.TimeGrid:
        options = self.modifiers(node, ("start", "stop", "interval"), "time(...)", with_units=True)
        values = self.scene_numbers(node, options, lambda k: f"time({k})", {}, dict.fromkeys(options, TIME))
        start, stop = values.get("start", 0.0), values.get("stop", DEFAULT_TIME.stop)
        interval = values.get("interval", (stop - start) / 1000 if "stop" in values else DEFAULT_TIME.interval)
        if not stop > start:
            raise LagError(f"the stop time {stop:g} is not after the start time {start:g}", self.span(node))
        if not interval > 0:
            raise LagError("the output interval must be positive", self.span(options.get("interval", node)))
        self.dims.scene_time(node)
        return ir.TimeGrid(start, stop, interval, self.span(node))

    def scene_stop(self, node) -> ir.StopCondition:
        """`stop when a < b;`: e = a - b (for `>`, b - a), a function of q, q', t, parameters and
        the multipliers λ (multiplier(c): the run solves for them with q'' wherever it evaluates e)."""
        left, right = expressions_of(node)
        sides = [self.expr.scalar(side, self.output_scope(), "a scalar in the stop condition")
                 for side in (left, right)]
        self.dims.scene_stop(left, right)
        function = sides[0] - sides[1] if tokens(node, "LESS") else sides[1] - sides[0]
        span = self.span(node)
        return ir.StopCondition(written(through(self.span(left), self.span(right))), function, span)

    def scene_integrator(self, node) -> ir.IntegratorChoice:
        token = tokens(node, "NAME")[0]
        name = str(token)
        check_integrator_name(name, self.span(token))
        record = registry.get(name)
        per_component = [m for m in subtrees(subtree(node, "modifiers")) if m.data == "component_modifier"] \
            if subtree(node, "modifiers") is not None else []
        atol_each = self.atol_each(per_component, name, "atol" in record.options)
        plain = _without(node, per_component)
        options = self.modifiers(plain, record.options, f"integrator {name}", with_units=True)
        words = {k: self.option_word(v, k, f"{name}({k} = ...)") for k, v in options.items() if OPTIONS[k].choices}
        for key, unit in self.written_units(plain).items():
            if key in words:
                raise LagError(f"{name}({key} = ...) takes a word, without a unit", unit.span)
        values = self.scene_numbers(plain, {k: v for k, v in options.items() if k not in words},
                                    lambda k: f"{name}({k} = ...)", {}, {k: TIME for k in options if OPTIONS[k].time})
        values.update(words)
        choice = validate_integrator(name, values, self.span(node), {k: self.span(v) for k, v in options.items()})
        return replace(choice, atol_each=atol_each)

    def option_word(self, node, key: str, what: str) -> float:
        """The index of the word an option of words is given (`norm = state`: 1), the value it holds."""
        option = OPTIONS[key]
        word = str(node.children[0]) if isinstance(node, lark.Tree) and node.data == "name" else None
        if word not in option.choices:
            raise LagError(f"{what} must be {option.requirement}", self.span(node))
        return float(option.choices.index(word))

    def atol_each(self, modifiers, name: str, takes_atol: bool) -> tuple[tuple[str, float], ...]:
        """`atol(x) = 1e-18`, `atol(der(x)) = 1e-6`: the atol of one component of y (tolerances.py), a
        plain number in the coordinate's declared unit (per second for a velocity), as `set` reads
        its start and velocity; in SI in the IR."""
        pairs, origins = {}, {}
        names = tuple(c.name for c in self.coordinates)
        declared = {key: unit for c in self.coordinates
                    for key, unit in ((f"{c.name}.start", c.unit), (f"{c.name}.velocity", units.per_second(c.unit)))}
        for modifier in modifiers:
            key, component = modifier.children[0], modifier.children[2]
            if str(key) != "atol" or not takes_atol:
                raise LagError(f"'{key}(...)' is not an option of integrator {name}: only atol is given per "
                               f"coordinate, and only to an adaptive integrator", self.span(key))
            text = component_key(written(self.span(component)))
            if text in pairs:
                raise LagError(f"atol({text}) is given twice", self.span(modifier))
            pairs[text] = self.numbers.number(modifier.children[-1], f"atol({text})", self.scope,
                                              declared.get(component_input(text, names)))
            origins[text] = self.span(modifier)
        check_atol_each(tuple(pairs.items()), names, registry.get(name).implicit, origins)
        return tuple(sorted(pairs.items()))

    def scene_set(self, node):
        token = tokens(node, "NAME")[0]
        binding = self.scope.bindings.get(str(token))
        parts = [c for c in subtrees(node) if c.data not in ("modifiers", "unit")]
        if binding is not None and binding.kind == "invalid":
            raise PoisonedName()
        if subtree(node, "modifiers") is None:        # set p = value
            if binding is not None and binding.kind == "coordinate":
                raise LagError(f"'{token}' is a coordinate; set its initial values with "
                               f"set {token}(start = ..., velocity = ...)", self.span(token))
            if binding is None or binding.kind != "parameter":
                parameters = [p.name for p in self.parameters]
                raise LagError(f"'{token}' is not a parameter{suggest(str(token), parameters)}", self.span(token))
            name = self.coordinate_member(token, binding, parts[0] if len(parts) == 2 else None,
                                          f"set {token}[i] = ...")
            parameter = next(p for p in self.parameters if p.name == name)
            if parameter.symbol in self.numbers.structural:
                raise LagError(f"'{name}' fixes the size of the model and cannot be changed by a scene",
                               self.span(token))
            written = self.unit(node)
            if written is not None:
                self.check_written_unit(written, units.dimension(parameter.unit) if parameter.unit else None,
                                        f"the value of {name}")
            value = self.numbers.number(parts[-1], "the value", self.scope, written or parameter.unit)
            self.dims.scene_set(node, token, binding.dimension)
            return ir.ParameterOverride(name, value, self.span(node))
        if binding is not None and binding.kind == "parameter":
            raise LagError(f"'{token}' is a parameter; set it with set {token} = ...", self.span(token))
        if binding is None or binding.kind != "coordinate":
            coordinates = [c.name for c in self.coordinates]
            raise LagError(f"'{token}' is not a coordinate{suggest(str(token), coordinates)}", self.span(token))
        name = self.coordinate_member(token, binding, parts[0] if parts else None,
                                      f"set {token}[i](start = ...)")
        options = self.modifiers(node, ("start", "velocity"), f"set {name}", with_units=True)
        unit = next(c.unit for c in self.coordinates if c.name == name)
        declared = {"start": unit, "velocity": units.per_second(unit)}
        values = self.scene_numbers(node, options, lambda k: f"the {k} value of {name}", declared,
                                    {k: units.dimension(u) for k, u in declared.items() if u is not None})
        self.dims.scene_set(node, token, binding.dimension)
        return ir.InitialOverride(name, values.get("start"), values.get("velocity"), self.span(node))

    def scene_numbers(self, node, options: dict, what, declared: dict, expected: dict) -> dict[str, float]:
        """The numbers of a scene statement's `options` (key: value node), in SI. A number is in
        the unit written after it, whose dimension must be expected[key] (a key not there takes
        none), else in declared.get(key) (None: SI); what(key) names it in messages."""
        written = self.written_units(node)
        values = {}
        for key, value in options.items():
            if key in written:
                self.check_written_unit(written[key], expected.get(key), what(key))
            values[key] = self.numbers.number(value, what(key), self.scope, written.get(key, declared.get(key)))
        return values

    @staticmethod
    def check_written_unit(unit: ir.Unit, expected: Dimension | None, what: str) -> None:
        if expected is None:
            raise LagError(f"{what} takes a plain number, without a unit", unit.span)
        found = units.dimension(unit)
        if found != expected:
            raise LagError(f"{what} must be {_words(expected)}, but [{unit.text}] is {_words(found)}", unit.span)

    def output_request(self, node, scene: str) -> ir.OutputRequest:
        span = self.span(node)
        column = written(span)
        outputs = {o.name for o in self.outputs}
        if node.data == "name" and str(node.children[0]) == "energy":
            self.dims.column(scene, node, None, outputs)
            return ir.OutputRequest(column, "energy", None, None, span)
        if node.data == "call" and str(node.children[0]) in OBSERVABLES:
            kind = str(node.children[0])
            items = call_arguments(node)
            if len(items) != 1 or items[0].data not in ("name", "index"):
                raise LagError(f"{kind}() takes one {'coordinate' if kind == 'momentum' else 'constraint'} name", span)
            target = self.target_name(kind, items[0])
            coordinate = self.scope.bindings[str(items[0].children[0])].dimension if kind == "momentum" else None
            self.dims.column(scene, node, coordinate, outputs)
            return ir.OutputRequest(column, kind, None, target, span)
        value = self.expr.scalar(node, self.output_scope(), "a scalar output")
        self.dims.column(scene, node, None, outputs)
        return ir.OutputRequest(column, "expression", value, None, span)


def _without(node: lark.Tree, modifiers: list) -> lark.Tree:
    """`node` with those of its modifiers left out (the per-component ones, read apart)."""
    block = subtree(node, "modifiers")
    if block is None or not modifiers:
        return node
    kept = lark.Tree("modifiers", [c for c in block.children if not any(c is m for m in modifiers)],
                     block.meta)
    return lark.Tree(node.data, [kept if c is block else c for c in node.children], node.meta)
