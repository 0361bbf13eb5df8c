"""A still render of a glTF file starts decoding the images its maps read while the process
is still importing the scene's modules, on the core those imports leave idle.

The maps the project filters (normal, metallic-roughness, occlusion) are decoded whole
whatever the camera (app/scene/gltf.py: the finest level a still frame samples only
decides where their levels start), and so is every colour map that is not a JPEG (only
libjpeg decodes at a reduced size): they can be decoded before the file is validated.
This reads the file's JSON with the standard library alone and decodes those images,
the filtered maps' first, on a thread of its own (``EARLY_THREADS``; app/textures/early.py),
Pillow letting go of the GIL while it decodes; a colour map's levels from level 1 on and a
normal map's sampled spread are made there too, once it is decoded. When the reader opens
the same bytes (their digest) it takes
that image instead of decoding them again (``maps.open_image``); every check of the
reader still runs there, in its order (header, budget, the broken image named by its
key). Nothing found here is reported: a file, a URI or an image this cannot
use is simply left to the reader. Only relative URIs confined as the reader confines them
(``files.confine_uri``) and plain files are read; a .glb's images are left to the reader.
"""

from __future__ import annotations

import json
import threading
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from app.untrusted.budget import Budget

# The textureInfo objects of a material whose images the project filters (decoded whole):
# (the material's object holding it, or None for the material itself, its key).
_WHOLE_MAPS = (
    ("pbrMetallicRoughness", "metallicRoughnessTexture"),
    (None, "normalTexture"),
    (None, "occlusionTexture"),
)
# Those of its colour maps (sRGB, whose mips the GL makes): decoded whole unless a JPEG.
_COLOUR_MAPS = (
    ("pbrMetallicRoughness", "baseColorTexture"),
    (None, "emissiveTexture"),
)
# One thread: the imports keep a core of their own on a 2-core machine, and every image
# is decoded before the reader needs it (docs/performance.md, "A real asset against f3d").
EARLY_THREADS = 1
_JPEG_SIGNATURE = b"\xff\xd8\xff"
# A glTF JSON larger than this is left to the reader (the early start is for the common case).
_MAX_JSON_BYTES = 16 << 20


def start_still_decodes(model: str | Path) -> None:
    """Start decoding ``model``'s whole-decoded images on a daemon thread, where ``model``
    names a .gltf file; nothing else. Their texels are charged to a budget of the default
    limits of their own (a render given a smaller ``--max-memory`` starts none)."""
    path = Path(model)
    if path.suffix.lower() != ".gltf":
        return
    threading.Thread(target=_start, args=(path,), name="pbs-early-images", daemon=True).start()


def _start(path: Path) -> None:
    from app.untrusted.budget import Budget
    from app.untrusted.policy import DEFAULT_POLICY

    try:
        budget = Budget(DEFAULT_POLICY.limits)  # the images decoded here: the default's
        doc = _document(path)  # read once
        whole = whole_image_uris(doc)
        colour = [uri for uri in whole_image_uris(doc, _COLOUR_MAPS) if uri not in whole]
        scales = normal_map_scales(doc)
    except Exception:  # the reader reports whatever is wrong, in its order
        return
    queue = iter([(uri, False) for uri in whole] + [(uri, True) for uri in colour])
    lock = threading.Lock()

    def drain() -> None:
        while True:
            with lock:
                item = next(queue, None)
            if item is None:
                return
            try:
                digest = _open(item[0], path, budget, skip_jpeg=item[1])
                if digest is not None and item[1]:
                    _colour_levels(digest)
                elif digest is not None:
                    for scale in scales.get(item[0], ()):
                        _normal_spread(digest, scale)
            except Exception:  # the reader reports whatever is wrong, in its order
                continue

    helpers = [
        threading.Thread(target=drain, name="pbs-early-images", daemon=True)
        for _ in range(EARLY_THREADS - 1)
    ]
    for helper in helpers:
        helper.start()
    drain()
    for helper in helpers:  # this thread ends with every early decode
        helper.join()


def whole_image_uris(
    path: Path | dict, maps: tuple[tuple[str | None, str], ...] = _WHOLE_MAPS
) -> list[str]:
    """The URIs of the images that ``path``'s materials (or a glTF document already read)
    read through the maps the project filters (``maps``: through those textureInfo
    objects instead), in the materials' order, each once (no data: URIs)."""
    uris: list[str] = []
    for _, uri in _map_uris(_document(path), maps):
        if not uri.startswith("data:") and uri not in uris:
            uris.append(uri)
    return uris


def normal_map_scales(path: Path | dict) -> dict[str, list[float]]:
    """The normal maps' URIs of ``path``'s materials (or of a glTF document already read),
    each with the normal scales it is read with (glTF's ``normalTexture.scale``, 1 where
    absent; a scale the reader would refuse is left out)."""
    scales: dict[str, list[float]] = {}
    for info, uri in _map_uris(_document(path), ((None, "normalTexture"),)):
        scale = info.get("scale", 1.0)
        if isinstance(scale, bool) or not isinstance(scale, int | float):
            continue
        if not -1e3 <= scale <= 1e3:  # the reader's bounds (app/scene/gltf.py)
            continue
        if float(scale) not in scales.setdefault(uri, []):
            scales[uri].append(float(scale))
    return scales


def _document(path: Path | dict) -> dict:
    """The glTF file's JSON, read with the standard library (a document passes through)."""
    if isinstance(path, dict):
        return path
    from app.untrusted import files
    from app.untrusted.policy import DEFAULT_POLICY

    limit = min(_MAX_JSON_BYTES, DEFAULT_POLICY.limits.max_file_bytes)
    return json.loads(files.read_bytes(path, limit))


def _map_uris(doc: dict, maps: tuple[tuple[str | None, str], ...]):  # -> Iterator
    """(textureInfo object, image URI) of every material's ``maps`` (held by the material or
    by one of its objects) whose texture and image indices are in range, in order."""
    textures, images = doc.get("textures") or [], doc.get("images") or []
    for material in doc.get("materials") or []:
        for holder, name in maps:
            owner = material if holder is None else material.get(holder) or {}
            info = owner.get(name) or {}
            index = info.get("index")
            if not isinstance(index, int) or not 0 <= index < len(textures):
                continue
            source = textures[index].get("source")
            if not isinstance(source, int) or not 0 <= source < len(images):
                continue
            uri = images[source].get("uri")
            if isinstance(uri, str):
                yield info, uri


def _normal_spread(digest: str, scale: float) -> None:
    """The sampled spread that ``render.normal_filter = "auto"`` chooses by, for the normal
    map decoded early with bytes of ``digest`` (``maps.auto_normal_filter``, kept in the
    prepared-texture cache under the key the reader's call looks up): made here, where
    the reader would make it on the main thread while reading the scene. Made too where
    the reader has taken the image already (it takes it while the decode runs): its call
    then waits for this build instead of making its own (``PreparedCache.arrays``)."""
    from app.textures.maps import auto_normal_filter

    image = _decoded_early(digest, taken_too=True)
    if image is not None:
        auto_normal_filter(image, scale)


def _colour_levels(digest: str) -> None:
    """A colour map decoded early gets its levels from level 1 on made here, on the core
    the imports leave idle (``maps.start_colour_levels``), where the reader would make
    them while the scene's exposure waits for the base colour. Nothing where the reader
    has taken the image already."""
    from app.textures.maps import start_colour_levels

    image = _decoded_early(digest)
    if image is not None:
        start_colour_levels(image)


def _decoded_early(digest: str, taken_too: bool = False):  # -> PIL.Image.Image | None
    """The image decoded early from the bytes of ``digest``, its digest recorded as
    ``maps.open_image`` records it (the key of what is made of it); None where the reader
    has taken it already, unless ``taken_too`` (``early.decoded``: while it is held)."""
    from app.textures import early
    from app.textures.maps import SOURCE_DIGEST

    image = early.decoded(digest) if taken_too else early.peek(digest)
    if image is not None:
        image.info[SOURCE_DIGEST] = digest
    return image


def _open(uri: str, path: Path, budget: Budget, skip_jpeg: bool = False) -> str | None:
    """The file ``uri`` names, decoded on this thread (``early.decode_early``); not where
    ``skip_jpeg`` and it is a JPEG (a colour map the reader may decode reduced). Its bytes'
    digest where it was decoded."""
    from app.textures.early import decode_early
    from app.untrusted import RefusedError, files
    from app.untrusted.policy import DEFAULT_POLICY

    try:
        file = files.confine_uri(uri, path, DEFAULT_POLICY)
        data = files.read_bytes(file, DEFAULT_POLICY.limits.max_file_bytes)
    except RefusedError:
        return None
    if skip_jpeg and data.startswith(_JPEG_SIGNATURE):
        return None
    return decode_early(data, budget)
