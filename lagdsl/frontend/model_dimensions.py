"""What the physics fixes about the dimensions of a model's statements (docs/language.md, "Units").

T, U, L and the energy function are energies; a force on q has the dimension of an energy divided
by q's; the dissipation function is a power; the sides of a constraint agree, and of a stop
condition; a parameter's value, a start value and a scene's values have the dimension of their
unit or quantity (a start velocity q's per time), and so has an output with a unit. A number
written for a quantity with a unit is in that unit and is not checked.

semantics.py calls these checks as it builds each statement, after the statement's expressions
(whose dimensions dimensions.py gave on the same walk); `finish` solves the equations and gives
the model its UnitReport. A model without any unit is not checked at all.
"""
from __future__ import annotations

import dataclasses

import lark

from .. import ir
from .dimensions import ENERGY, POWER, TIME, DimensionCheck, Form, components
from ..errors import Diagnostic, LagError
from .functions import BUILTINS
from ..source import SourceFile, Span
from .tree import call_arguments, modifier_items, span_of, subtree, subtrees, uses_names, written
from .units import dimension, is_angle, si_factor

# The group of ORDER (dimensions.py) each statement's equations are solved in.
GROUPS = {"parameter": "declaration", "coordinate": "declaration", "let": "declaration",
          "force": "force", "dissipation": "force", "constraint": "force", "energy": "energy",
          "output": "output", "scene": "scene"}


class ModelDimensions:
    """The dimension checks of a model's statements, and the UnitReport."""

    def __init__(self, source: SourceFile):
        self.source = source
        self.check = DimensionCheck(source)
        self.units: dict[str, ir.Unit] = {}             # name -> unit, for the names declared with one
        self.undeclared: dict[str, Span] = {}           # quantities declared without a unit
        self.coordinates: set[str] = set()
        self.energies: dict[str, Form] = {}
        self.columns: list[tuple[str, str, object]] = []        # scene, column, Form or unit text
        self.scaled: dict[tuple[str, str], object] = {}          # (scene, column) -> factor

    def start(self, statement: str) -> None:
        """The equations recorded from now on come from a statement of this kind."""
        self.check.group = GROUPS[statement]

    def _unit_check(self, value: Form, unit: ir.Unit, node, subject: str) -> None:
        expected = Form(dimension(unit))
        self.check.require(value, expected, node, lambda: f"{self.check.has(subject, value)} but its unit "
                                                          f"[{unit.text}] {self.check.has('', expected, True)[1:]}")

    # -- declarations --------------------------------------------------------------------------
    def declared(self, token, unit: ir.Unit | None) -> Form:
        """A quantity's dimension: its unit's, or an unknown to infer."""
        if unit is not None:
            self.units[str(token)] = unit
            return Form(dimension(unit))
        self.undeclared[str(token)] = span_of(token, self.source)
        return Form.unknown(str(token))

    def parameter(self, token, unit: ir.Unit | None, value_node) -> Form:
        """A parameter, or a parameter array whose unit applies to every member: a number is in the
        unit, an expression of earlier parameters must have the unit's dimension."""
        members = self._members(value_node)
        if not members:                              # numbers only, in the unit
            return self.declared(token, unit)
        if unit is not None:
            self.units[str(token)] = unit
            for item, value in members:
                self._unit_check(value, unit, item, f"the value of {token}")
            return Form(dimension(unit))
        first_node, first = members[0]
        for item, value in members[1:]:
            self.check.differ(value, item, first, first_node, "this member", "the first member",
                              f"the members of {token} differ: ")
        return first

    def _members(self, node) -> list[tuple[lark.Tree, Form]]:
        """The members of a family's value that use names, with their dimensions: one value for
        all, a list {a, b, ...}, or a list given by its index {e, i in 1:n} (e read with i a plain
        number). A member written with numbers (and the index) only is a number in the unit."""
        items = subtrees(node) if node.data == "braces" else [node]
        if items[-1].data == "iteration":
            variable = str(items[-1].children[0])
            return [(items[0], self.check.scalar(items[0]))] if uses_names(items[0], variable) else []
        return [(item, self.check.scalar(item)) for item in items if uses_names(item)]

    def coordinate(self, token, unit: ir.Unit | None, node) -> Form:
        self.coordinates.add(str(token))
        form = self.declared(token, unit)
        self.initial_values(node, str(token), form)
        return form

    def initial_values(self, node, name: str, form: Form) -> None:
        """start = ... and velocity = ...: a number is in the coordinate's unit, an expression of
        parameters must have the coordinate's dimension (its velocity's)."""
        for key, value_node in modifier_items(node):
            expected, owner = (form, name) if str(key) == "start" else (form / Form(TIME), f"der({name})")
            what = "the start value" if str(key) == "start" else "the start velocity"
            for item, value in self._members(value_node):
                self.check.require(value, expected, item,
                                   lambda value=value, expected=expected, owner=owner, what=what:
                                   f"{self.check.has(f'{what} of {name}', value)} but "
                                   f"{self.check.has(owner, expected, True)}")

    def family(self, name: str) -> Form:
        """The dimension of an indexed let's members while they are built: x[i] may use x[i - 1],
        so it is an unknown that the body must equal."""
        return Form.unknown(f"{name}[i]")

    def of(self, expression) -> object:
        """The dimension of a built expression (the value of a let, an output)."""
        return self.check.form(expression)

    def family_body(self, name: str, body) -> object:
        """The dimension of an indexed let's members (any, if it has none: its body is not built)."""
        value = self.check.built_form(body)
        if isinstance(value, Form):
            members = self.family(name)
            self.check.require(value, members, body,
                               lambda: f"{self.check.has(self.check.quoted(body, 'the body'), value)} but the "
                                       f"members it uses {self.check.has('', members, True)[1:]}")
        return value

    # -- what the physics fixes ----------------------------------------------------------------
    def energy(self, kind: str, body) -> None:
        """T, U, L: energies; a mistake names the other energy's dimension when that one is right."""
        value = self.energies[kind] = self.check.scalar(body)
        other = {"T": "U", "U": "T"}.get(kind)

        def message():
            has = self.check.has
            if other in self.energies and self.check.solver.resolve(self.energies[other]) == Form(ENERGY):
                return f"{has(kind, value)} but {has(other, self.energies[other], True)}"
            what = "a Lagrangian is an energy" if kind == "L" else "an energy has dimension"
            return f"{has(kind, value)}, but {what} {ENERGY.words()}"
        self.check.require(value, Form(ENERGY), body, message, group="energy total")

    def dissipation(self, body) -> None:
        value = self.check.scalar(body)
        self.check.require(value, Form(POWER), body,
                           lambda: f"{self.check.has('the dissipation function', value)}, but it must be a "
                                   f"power, {POWER.words()}")

    def force(self, token, index_node, coordinate: Form, body) -> None:
        """A generalized force on q: an energy divided by q's dimension."""
        name = str(token) + (f"[{written(span_of(index_node, self.source))}]" if index_node is not None else "")
        value, expected = self.check.scalar(body), Form(ENERGY) / components(coordinate)[0]
        self.check.require(value, expected, body,
                           lambda: f"{self.check.has(f'the force on {name}', value)}, but a force on {name} has "
                                   f"{self.check.words(expected)} (an energy divided by the dimension of {name})")

    def constraint(self, name: str, lhs, rhs, holonomic: bool) -> None:
        left, right = self.check.scalar(lhs), self.check.scalar(rhs)
        self.check.differ(right, rhs, left, lhs, "the right side", "the left side",
                          f"the sides of constraint {name} differ: ")
        self.check.constraints[name] = (right if left.wild else left, holonomic)

    def output(self, token, unit: ir.Unit | None, body) -> None:
        """An output declared with a unit has the unit's dimension."""
        if unit is not None:
            self.units[str(token)] = unit
            self._unit_check(self.check.scalar(body), unit, body, f"the output {token}")

    # -- scenes --------------------------------------------------------------------------------
    def scene_time(self, node) -> None:
        """time(start = ..., stop = ..., interval = ...): an expression of parameters is a time."""
        for key, value_node in modifier_items(node):
            if uses_names(value_node):
                value = self.check.scalar(value_node)
                self.check.require(value, Form(TIME), value_node,
                                   lambda value=value, key=key, node=value_node:
                                   f"time({key} = ...) must be a time, but "
                                   f"{self.check.has(self.check.quoted(node, 'it'), value)}")

    def scene_set(self, node, token, form: Form) -> None:
        """set p = ... of a parameter's dimension; set q(start = ..., velocity = ...) as a coordinate's."""
        form = components(form)[0]
        if subtree(node, "modifiers") is not None:
            self.initial_values(node, str(token), form)
            return
        value_node = [c for c in subtrees(node) if c.data != "modifiers"][-1]
        if uses_names(value_node):
            value = self.check.scalar(value_node)
            self.check.require(value, form, value_node,
                               lambda: f"{self.check.has(f'the value set for {token}', value)} "
                                       f"but {self.check.has(str(token), form, True)}")

    def scene_stop(self, left, right) -> None:
        self.check.differ(self.check.scalar(right), right, self.check.scalar(left), left, "the right side",
                          "the left side", "the sides of the stop condition differ: ")

    def column(self, scene: str, node, target: Form | None, outputs: set[str]) -> None:
        """The unit of one column of a scene's output list (and the factor of an output's unit);
        `target` is the dimension of the coordinate of momentum(q)."""
        column = written(span_of(node, self.source))
        name = str(node.children[0]) if node.data in ("name", "call") else None
        if node.data == "name" and name == "energy":
            self.columns.append((scene, column, Form(ENERGY)))
        elif node.data == "name" and name in self.units and name in outputs:
            self.columns.append((scene, column, self.units[name].text))     # written in its own unit
            self.scaled[(scene, column)] = si_factor(self.units[name])
        elif node.data == "call" and BUILTINS.get(name) and BUILTINS[name].kind == "observable":
            arguments = call_arguments(node)
            if target is not None:
                self.check.leaf(arguments[0], target)
            self.check.call(node, BUILTINS[name], arguments)
            self.columns.append((scene, column, self.check.scalar(node)))
        else:
            self.columns.append((scene, column, self._angle_unit(node) or self.check.scalar(node)))

    def _angle_unit(self, node) -> str | None:
        """"rad" for a coordinate with an angle unit, "rad/s" for its der(): radians are shown."""
        if node.data == "call" and str(node.children[0]) == "der":
            inner = self._angle_unit(call_arguments(node)[0])
            return inner and inner + "/s"
        if node.data in ("name", "index"):
            unit = self.units.get(str(node.children[0]))
            coordinate = str(node.children[0]) in self.coordinates
            return "rad" if coordinate and unit is not None and is_angle(unit) else None
        return None

    # -- the result ----------------------------------------------------------------------------
    def finish(self, model: ir.Model, dimension_of) -> ir.Model:
        """The model with its UnitReport, values of outputs declared with a unit written in it;
        `dimension_of` gives the dimension of a declared name. Raises one LagError with every
        dimensional mistake found."""
        if not any(q.unit for q in (*model.parameters, *model.coordinates, *model.outputs)):
            return model
        errors = self.check.solve()
        if errors:
            error = LagError.combine(errors)
            error.diagnostics = tuple(sorted(error.diagnostics, key=lambda d: d.span.start))
            raise error
        notes = tuple(Diagnostic(f"the unit of '{name}' could not be inferred, so what uses it was not checked; "
                                 "give it a unit", span, "note")
                      for name, span in self.undeclared.items()
                      if self.check.solver.resolve(Form.unknown(name)).unknowns)
        return dataclasses.replace(model, units=self._report(model, dimension_of, notes),
                                   scenes=self._scaled_scenes(model))

    def _report(self, model: ir.Model, dimension_of, notes) -> ir.UnitReport:
        quantities = []
        for q in (*model.parameters, *model.coordinates):
            base = q.name.split("[")[0]
            unit = self.units.get(base)
            shown = "rad" if unit is not None and is_angle(unit) else self.check.si(dimension_of(base))
            quantities.append((q.name, shown, unit is None))
        for o in model.outputs:
            unit = self.units.get(o.name)
            quantities.append((o.name, unit.text if unit is not None else self.check.si(dimension_of(o.name)),
                               unit is None))
        columns = tuple((scene, column, value if isinstance(value, str) else self.check.si(value))
                        for scene, column, value in self.columns)
        return ir.UnitReport(tuple(quantities), columns, notes)

    def _scaled_scenes(self, model: ir.Model) -> tuple[ir.Scene, ...]:
        """Scenes whose output lists name an output declared with a unit: written in that unit."""
        scenes = []
        for scene in model.scenes:
            outputs = tuple(dataclasses.replace(o, expression=o.expression / self.scaled[(scene.name, o.column)])
                            if (scene.name, o.column) in self.scaled else o for o in scene.outputs)
            scenes.append(dataclasses.replace(scene, outputs=outputs))
        return tuple(scenes)
