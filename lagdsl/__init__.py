"""lagdsl: a compiler for Lagrangian mechanics."""
__version__ = "0.1.0"
