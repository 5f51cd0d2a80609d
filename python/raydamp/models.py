"""The built-in models, by their public name: ``raydamp.models.DampedPendulum``,
``from raydamp.models import ElasticPendulum``.

They live in :mod:`raydamp.systems.models` with the other kinds of system; this module is
their public namespace and re-exports them.
"""

from .systems.models import MODELS, DampedPendulum, ElasticPendulum, Model, describe_models, make_model

__all__ = ["Model", "DampedPendulum", "ElasticPendulum", "MODELS", "describe_models", "make_model"]
