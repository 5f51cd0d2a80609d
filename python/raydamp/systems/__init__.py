"""What raydamp integrates: the kinds of mechanical system, each turned into a compiled model.

models.py (the built-in models, public as :mod:`raydamp.models`), system/ (a user's System from
expressions or functions, compiled), expressions/ (the parser and trees of a System's text),
chain.py (lattices of up to millions of sites), structure.py (linear structures: M, K, Rayleigh
damping, sparse), rayleigh.py (alpha, beta from modal damping ratios), kinds.py (every kind as
the plain data a job names, both ways).
"""
