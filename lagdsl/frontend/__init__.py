"""The front end: text -> lark Tree -> ir.Model, with every node's dimension found on the same walk.

parser.py (grammar.lark) parses; semantics.py walks the tree once, statement by statement
(declarations.py, equation_statements.py, scene_statements.py), building expressions node by node
(expressions.py, calls.py, constants.py, compile_time.py, values.py over tree.py's helpers) and
their dimensions (dimensions.py, model_dimensions.py, units.py); functions.py is the table of
built-in functions that the printers and the C runtime read too.
"""
