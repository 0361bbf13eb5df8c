"""The constants GLSL shares with Python, generated from their one definition here.

``shared_defines()`` is what app/gl/shaders.py writes at the top of every program: the model
names of each BRDF term (``FRESNEL_SCHLICK 0``, ``NDF_GGX 0``, ...), the ``TERM_*`` bits
of ``render.terms``, the light types (``LIGHT_DIRECTIONAL 0``, ...), the tone maps
(``TONEMAP_NEUTRAL 1``, ...), the debug views (``DEBUG_NDF 8``, ...) and the blocks of
the multiple-scattering tables (``MS_FORMS``, ``MS_FORM_SEPARABLE 1``, ...). No GLSL file
writes these numbers itself.
"""

from __future__ import annotations

from functools import cache

from app.common import debug_views, lights, models, tables, tonemaps


@cache
def shared_defines() -> dict[str, int]:
    """Name -> value, in a stable order; the names of the sources never collide."""
    out: dict[str, int] = {}
    parts = (models, lights, tonemaps, debug_views, tables)
    for part in (module.glsl_constants() for module in parts):
        clash = out.keys() & part.keys()
        if clash:
            raise ValueError(f"GLSL constants defined twice: {sorted(clash)}")
        out.update(part)
    return out
