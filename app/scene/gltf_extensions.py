"""glTF KHR_materials_* extensions mapped onto the project's models (issue 17, part c).

A placeholder so that the glTF reader (app/scene/gltf.py) runs: the extension engineer's
module replaces it. The reader calls ``material_extensions`` once per glTF material with
the material's ``extensions`` object.
"""

from __future__ import annotations

from app.common.models import MaterialParams


def material_extensions(extensions: dict, params: MaterialParams, key: str) -> MaterialParams:
    """The material's constants after its extensions (``key``: its JSON path, for
    errors); here unchanged."""
    return params
