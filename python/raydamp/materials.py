"""The hysteretic materials of a :class:`raydamp.Structure`'s springs, by their public name:
``raydamp.materials.Bilinear(k, fy, b)``.

They live in :mod:`raydamp.systems.materials` with the structure; this module is their public namespace.
"""

from .systems.materials import MATERIALS, Bilinear, BoucWen, ElasticPlastic, Material, material_from_dict

__all__ = ["Material", "ElasticPlastic", "Bilinear", "BoucWen", "MATERIALS", "material_from_dict"]
