"""What raydamp integrates: the kinds of mechanical system, each turned into a compiled model.

Every kind answers the same few questions (kinds.py's SystemKind protocol: its names, its JSON
form, which parameters may vary per ensemble member, what the compiled ensemble runs), so the
layers above ask instead of switching on its type.

models.py (the built-in models, public as :mod:`raydamp.models`; their parameters are the core's
tables, _core.models()), system/ (a user's System from expressions or functions, compiled),
expressions/ (the parser and trees of a System's text), chain.py (lattices of up to millions of
sites), structure.py (linear structures: M, K, Rayleigh damping, sparse), rayleigh.py (alpha,
beta from modal damping ratios), kinds.py (the protocol, and a model as the plain data a job names).
"""
