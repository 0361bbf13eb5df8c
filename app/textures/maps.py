"""A material's texture maps, read from the files a scene names and turned into the mip
chains the G-buffer pass samples (RTR4 §9.13).

Colour data (base colour) is sRGB and lets the GL build its mips. Non-colour data never
does: masks, metallic and anisotropy get box-filtered mips (mips.box_mips), and roughness
travels with the normals in one RGBA16F chain (xyz = tangent-space normal, a =
perceptual roughness) built by app/textures/mips.py, so that the variance of the normals a
texel averages moves into its roughness (the scene's ``render.normal_filter``).

The chains a file's images give are kept in app/textures/cache.py's content-keyed cache
(``normal_roughness_map``, ``channel_texture``): a second load of the same images, in this
process or the next, reads them instead of building them. Such a chain's levels
(``PreparedLevels``) are read only when first indexed; the GL's 16-bit float levels are an
entry of their own, so that a render reads half the bytes and converts none.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import PIL
from PIL import Image

from app.common.models import MaterialParams
from app.errors import InputError
from app.reference.filtering import directional_spread
from app.textures import decoded as decoded_images
from app.textures.cache import prepared_cache
from app.textures.early import (
    BAND_BYTES,
    DECODES,
    charge_decode,
    decode_record,
    decoded_before,
    open_header,
    single_idat,
    unreadable,
)
from app.textures.early import take as take_early
from app.textures.lean import AUTO, LEAN, covariance_levels, lean_chain_levels, spread_levels
from app.textures.mips import (
    BandSource,
    box_mips,
    chain_inputs,
    chain_levels,
    decode_normal_map,
    float16_rows_up,
    srgb_box_levels,
    unorm8_box_levels,
)
from app.textures.pillow_view import rgbx_view
from app.textures.versions import version
from app.untrusted import RefusedError, files
from app.untrusted.budget import Budget
from app.untrusted.policy import Limits
from app.waiting import GL_CHAIN, before_waiting, offer, waited

MAX_TEXTURE_SIZE = Limits().max_texture_side  # texels per side (the default limit)
# Image.info key of the SHA-256 of the bytes an image was decoded from (open_image).
SOURCE_DIGEST = "pbs_source_sha256"
# Image.info key of how many finest levels ``open_image``'s DCT scaling left out.
REDUCED_LEVELS = "pbs_reduced_levels"


@dataclass
class Texture:
    """One material map: its mip levels, level 0 first, rows top to bottom.

    ``srgb``: colour data stored as sRGB8 and decoded by the GL, which also builds its mips
    (``levels`` then holds level 0 only, or every level where ``colour_texture`` made them
    of a DCT-scaled image); otherwise every level is given here.
    """

    levels: Sequence[np.ndarray]  # (h, w, c) uint8 or float32 (a list, or PreparedLevels)
    srgb: bool = False
    # Sampler state (glTF 2.0 ``samplers``): wrap along u and v, each "repeat", "clamp"
    # or "mirror"; the GL's minification and magnification filters by their glTF names
    # ("nearest", "linear", "nearest_mipmap_nearest", ..., "linear_mipmap_linear").
    wrap: tuple[str, str] = ("repeat", "repeat")
    min_filter: str = "linear_mipmap_linear"
    mag_filter: str = "linear"
    # For colour data: what its file's content is (``SOURCE_DIGEST`` and Pillow's version),
    # where known, so that the GL's mips of it can be kept (app/render/texture_upload.py).
    source_key: str | None = None
    # A normal/roughness chain's maker with another roughness factor, from the images
    # this one keeps (``normal_roughness_map``): a factor edit makes no file read
    # or decode (app/scene/file_materials.py). None for every other map.
    with_factor: Callable[[float], Texture] | None = field(default=None, compare=False, repr=False)

    @property
    def pixels(self) -> np.ndarray:
        return self.levels[0]


class PreparedLevels(Sequence[np.ndarray]):
    """The float32 levels of a chain kept in the prepared-texture cache (app/textures/
    cache.py), looked up (read, or built and kept) when first indexed, not when made.

    ``upload_levels`` gives what the GL stores instead (app/render/texture_upload.py):
    every level as float16, rows bottom first, kept as an entry of its own under the same
    key parts. A render then reads those (half the bytes of the float32 levels, which it
    never reads) and converts nothing; the float32 levels are still what ``levels[k]`` is
    for a consumer on the CPU. On a miss the float16 levels are built from the float32
    ones (exactly ``np.float16`` of them, the conversion upload did before), which are
    kept on disk only when something indexes them: a render's entries are the float16
    levels alone (docs/filtering.md)."""

    def __init__(
        self,
        kind: str,
        parts: tuple,
        build: Callable[[], Sequence[np.ndarray]],
        layout: tuple[int, int, int, bool],
        build_upload: Callable[[], Sequence[np.ndarray]] | None = None,
        gl_source: ChainSource | None = None,
    ) -> None:
        self.kind, self.parts, self._build = kind, parts, build
        # What the GL builds the float16 levels from where it can (a render's upload, app/
        # render/texture_upload.py); a consumer on the CPU builds them as ever
        self.gl_source = gl_source
        # ``upload_levels``'s float16 levels made directly (the same bits as converting
        # ``build``'s, without holding float32 copies of the levels), where given
        self._build_upload = build_upload
        # (height, width, components, level 0 alone) of what build makes: its GL bytes are
        # known (``upload_bytes``) before the levels are read or built
        self.layout = layout
        self._levels: list[np.ndarray] | None = None
        self._prefetched: Future | None = None

    def _loaded(self) -> list[np.ndarray]:
        if self._levels is None:
            self._levels = list(prepared_cache().arrays(self.kind, self.parts, self._build))
        return self._levels

    def __getitem__(self, index):  # type: ignore[override]  # an int or a slice, as a list's
        return self._loaded()[index]

    def __len__(self) -> int:
        return len(self._loaded())

    def prefetch(self, gl: bool = True) -> None:
        """Start getting the float16 levels on the cache's background thread (read from
        disk, or built and kept where they are not there): ``upload_levels`` then waits
        for that instead of doing it itself. A chain the GL can build (``gl``: the GL
        that uploads it can draw it) is only read here, where its GL-built levels are
        kept: else the upload draws it."""
        if self._prefetched is not None:
            return
        kind = _UPLOAD_KIND % self.kind
        if self.gl_source is not None and gl:
            if prepared_cache().holds(kind, self.gl_parts):
                self._prefetched = prepared_cache().prepare_kept(kind, self.gl_parts)
            return
        self._prefetched = prepared_cache().prepare(kind, self.parts, self._upload_build)

    @property
    def gl_parts(self) -> tuple:
        """The cache key parts of the float16 levels the GL built."""
        return (*self.parts, GL_BUILT, gl_chain_version())

    @property
    def gl_kind(self) -> str:
        """The cache kind of the float16 levels (the GL's as the CPU's)."""
        return _UPLOAD_KIND % self.kind

    def prefetched(self) -> bool:
        """Whether ``prefetch`` started reading (or building) the float16 levels."""
        return self._prefetched is not None

    def ready(self) -> bool:
        """Whether ``upload_levels`` has nothing to wait for (prefetched and at hand)."""
        return self._prefetched is not None and self._prefetched.done()

    def upload_levels(
        self, redraw: Callable[[], Sequence[np.ndarray]] | None = None
    ) -> list[np.ndarray]:
        """Every level as the GL takes it: float16, rows bottom first, contiguous. Where
        the GL-built levels a prefetch looked for were gone by the time it read them
        (evicted, or a damaged file), ``redraw()``'s where given (the GL draws them again:
        the bits a cold render draws), else the CPU's, which differ from the GL's in the
        last bits."""
        if self._prefetched is not None:
            prefetched = self._prefetched.result()
            if prefetched is not None:
                return list(prefetched)
            self._prefetched = None  # the GL-built levels were gone by the time it read
            if redraw is not None:
                return list(redraw())
        kind = _UPLOAD_KIND % self.kind
        return list(prepared_cache().arrays(kind, self.parts, self._upload_build))

    def _upload_build(self) -> list[np.ndarray]:
        if self._levels is None and self._build_upload is not None:
            return list(self._build_upload())
        if self._levels is None:  # built, not kept on disk: a render never reads them again
            self._levels = [np.asarray(level) for level in self._build()]
        return [float16_rows_up(level) for level in self._levels]


_UPLOAD_KIND = "%s f16 rows up"  # the cache kind of a chain's float16 levels


# A key part of the float16 levels of a chain the GL built (app/render/normal_chain.py):
# float32 moments, not the float64 ones, so not the same bits as the CPU's. Not keyed by
# the GL's renderer (a prefetch looks the levels up before the GL is started): every GL's
# are held to the float64 chain within one float16 step, so another GL's entry is as near.
GL_BUILT = "built by the GL"


def gl_chain_version() -> str:
    """The code version of a chain the GL draws (app/textures/versions.py)."""
    return version("gl chain")


@dataclass(frozen=True, eq=False)  # two sources are the same only when they are one
class ChainSource:
    """What the GL needs to build a ``variance`` normal/roughness chain itself
    (app/render/normal_chain.py): the normal map, the roughness image (its green channel,
    the normal map's size) or None, the material's normal scale and roughness factor, and
    the first level kept (``normal_roughness_map``'s ``first``)."""

    normal_image: Image.Image = field(compare=False)
    roughness_image: Image.Image | None = field(compare=False)
    scale: float
    factor: float
    first: int

    @property
    def shape(self) -> tuple[int, int]:
        return (self.normal_image.height, self.normal_image.width)

    def normal_texels(self) -> np.ndarray:
        """The normal map's 8-bit texels, (H, W, 4) where Pillow's storage can be read
        in place (the 4th byte its padding), else (H, W, 3)."""
        view = _stored_rgbx(self.normal_image)
        return view if view is not None else rgb_texels(self.normal_image)

    def texels_in_place(self) -> list[np.ndarray] | None:
        """The normal map's and (where there is one) the roughness image's decoded storage
        as (H, W, 4) uint8 views, the 4th byte Pillow's padding (app/textures/pillow_view.py
        ``rgbx_view``), for the GL to read in place; None where either image is no RGB
        image whose storage Pillow exports in one piece."""
        images = (self.normal_image, self.roughness_image)
        views = [_stored_rgbx(image) for image in images if image is not None]
        return None if any(view is None for view in views) else views

    def roughness_texels(self) -> np.ndarray | None:
        """The roughness image's green channel, (H, W) uint8, or None."""
        if self.roughness_image is None:
            return None
        return np.ascontiguousarray(rgb_texels(self.roughness_image)[..., 1])


def prefetch_uploads(layers: Iterable[SurfaceLayer]) -> None:
    """Start reading the float16 levels of the layers' prepared maps in the background:
    a model file's parts are built (and its camera framed, its exposure metered, the GL
    started) well before the renderer uploads them."""
    for layer in layers:
        for tex in layer.maps.values():
            prefetch_map(tex)


def prefetch_map(tex: Texture) -> None:
    """``PreparedLevels.prefetch`` of a prepared map (nothing for any other): a glTF
    material's maps start as they are read (app/scene/gltf.py)."""
    if isinstance(tex.levels, PreparedLevels):
        tex.levels.prefetch()


def upload_bytes(tex: Texture) -> int:
    """The bytes of a non-colour map's float16 levels (``upload_levels``), without reading
    or building a prepared chain's (its declared layout: GL sizes down to 1x1)."""
    if not isinstance(tex.levels, PreparedLevels):
        return sum(level.size * 2 for level in upload_levels(tex))
    h, w, comps, single = tex.levels.layout
    total, k = 0, 0
    while True:
        total += max(1, h >> k) * max(1, w >> k) * comps * 2
        if single or max(h >> k, w >> k) <= 1:
            return total
        k += 1


def upload_levels(tex: Texture) -> list[np.ndarray]:
    """A non-colour map's levels as the GL stores them (float16, rows bottom first)."""
    if isinstance(tex.levels, PreparedLevels):
        return tex.levels.upload_levels()
    return [np.ascontiguousarray(level[::-1], np.float16) for level in tex.levels]


@dataclass(frozen=True)
class UvTransform:
    """Which texture coordinates a map reads and how they are moved first (glTF 2.0
    ``texCoord`` and KHR_texture_transform): uv' = T(offset) R(rotation) S(scale) uv,
    rotation in radians, counter-clockwise in UV space as the extension defines it. The
    layer's ``uv_scale`` multiplies uv' afterwards."""

    uv_set: int = 0  # 0: TEXCOORD_0, 1: TEXCOORD_1 (MeshPart.uv1)
    offset: tuple[float, float] = (0.0, 0.0)
    rotation: float = 0.0
    scale: tuple[float, float] = (1.0, 1.0)

    @property
    def identity(self) -> bool:
        return self == UvTransform()


@dataclass
class SurfaceLayer:
    """One material as the G-buffer pass samples it: constants, maps and UV tiling.

    ``maps`` keys: ``base_color`` (sRGB), ``metallic``, ``anisotropy`` (R), ``emissive``
    (sRGB), ``occlusion`` (R), ``anisotropy_direction`` (RG: the direction of anisotropy
    in (t, b), decoded to [-1, 1]; ``direction_texture``), and
    ``normal_roughness`` (RGBA: normal xyz, absolute perceptual roughness; present when the
    material has a normal or a roughness map), ``coat_normal`` (RGBA: the clear coat's own
    normal xyz, its own mips; RTR4 §9.12), ``sheen_color`` or ``specular_color`` (sRGB) and
    ``clearcoat`` (R): per-pixel factors on the material row's sheen or specular colour and
    coat strength (glTF sheenColorTexture, specularColorTexture, clearcoatTexture;
    G-buffer RT6). ``normal_mapped``: the base's
    normals come from a normal map (a roughness map alone keeps them flat).
    """

    params: MaterialParams
    maps: dict[str, Texture] = field(default_factory=dict)
    uv_scale: tuple[float, float] = (1.0, 1.0)
    normal_mapped: bool = False
    # glTF 2.0 core material beyond metallic-roughness. ``emissive``: emitted
    # radiance added to the pixel (emissiveFactor x KHR_materials_emissive_strength),
    # times the ``emissive`` map (sRGB RGB) where present. ``occlusion`` map (R, linear):
    # 1 + strength (occlusion - 1) darkens environment light only. ``alpha``: coverage
    # (baseColorFactor's A, times the base colour map's A and COLOR_0's A); ``alpha_mode``
    # "opaque" ignores it, "mask" discards below ``alpha_cutoff``, "blend" composites.
    emissive: tuple[float, float, float] = (0.0, 0.0, 0.0)
    occlusion_strength: float = 1.0
    alpha: float = 1.0
    alpha_mode: str = "opaque"
    alpha_cutoff: float = 0.5
    # glTF KHR_materials_anisotropy's anisotropyRotation (RTR4 §9.8), radians: the direction
    # of anisotropy (the ``anisotropy_direction`` map's, else t) turned counter-clockwise
    # from t towards b. Layer 0's only: the G-buffer has one tangent per pixel.
    anisotropy_rotation: float = 0.0
    # Per map key: its UV set and KHR_texture_transform; a key not here reads TEXCOORD_0
    # untransformed.
    uv_transforms: dict[str, UvTransform] = field(default_factory=dict)

    @property
    def own_coat_normal(self) -> bool:
        """Whether the layer's clear coat shades with a normal other than its base's (the
        G-buffer then carries RT4, docs/gbuffer.md). glTF KHR_materials_clearcoat: without
        a clearcoatNormalTexture "no normal mapping is applied to the clear coat layer,
        even if normal mapping is applied to the base material", so a coat over a
        normal-mapped base has the vertex normal; with one, the coat's own map."""
        coated = self.params.model.clearcoat != "none"
        return coated and (self.normal_mapped or "coat_normal" in self.maps)


def open_image(
    source: Path | bytes,
    budget: Budget | None = None,
    kind: str | None = "colour",
    decode_later: bool = False,
    reduce: Callable[[int, int], int] | None = None,
) -> Image.Image:
    """A texture (a plain file, or bytes from a glTF buffer) decoded, or ``RefusedError``.

    Decoded here unless the prepared-texture cache (app/textures/cache.py) records that
    these very bytes decoded before under this Pillow: an entry "decodes" keyed by their
    SHA-256 is written only after a decode succeeds, so a broken image is still refused
    here, and an image known to decode is returned undecoded, its texels decoded when
    first read. A warm render of a model file then decodes only the maps it uploads from
    the texels (colour maps), not those whose prepared chains it reads from the cache.

    The size the header declares is checked before a pixel is decoded: at most
    ``Limits.max_texture_side`` a side, and the decoded texels plus what the map of
    ``kind`` (colour, scalar, normal, direction; None: the caller charges the map) builds
    from them charged to ``budget``.
    Only ``IMAGE_FORMATS`` are parsed, and Pillow's own size warnings stay off stderr
    (the header check above is what refuses an oversized image).

    ``decode_later``: the header is read, checked and charged here as above, and the
    decode (with its check against the cache's record) runs on a pool of two threads
    (Pillow lets go of the GIL while it decodes): a caller that opens several images
    decodes them side by side and beside its own work. Whoever reads the texels waits
    for it (``_decoded``); the caller asks ``wait_decoded`` for the verdict (the
    ``RefusedError`` a broken image raises) before it relies on one.

    ``reduce``: how many of the finest mip levels of an image of the header's size a
    still frame never samples (app/scene/sampled_levels.py), n; a JPEG is then decoded
    at 1/2^n of its size by libjpeg's DCT scaling (Pillow's ``draft``), and everything
    made from it (its mips, the cache's entries, keyed by the decoded size) starts
    there. Other formats decode whole. The header's size is what is checked and charged."""
    budget = budget or Budget()
    try:
        if isinstance(source, bytes):
            encoded = source
        else:
            encoded = files.read_bytes(Path(source), budget.limits.max_file_bytes)
        # Not a ``with`` block: an image returned undecoded reads its stream later.
        image = open_header(encoded)
        width, height = image.size  # from the header: checked before decoding
        charge_decode(image, budget, kind)
        # What the prepared-texture cache keys this image by (_image_part): the
        # file's bytes, a few MiB to hash where the decoded texels are tens.
        digest = hashlib.sha256(encoded).hexdigest()
        skipped = reduce(width, height) if reduce is not None else 0
        if skipped and image.format == "JPEG":
            reduced = (width >> skipped, height >> skipped)
            image.draft(image.mode, reduced)
            if image.size != reduced:  # a scale libjpeg does not make: the whole image
                image = open_header(encoded)
            else:  # another image than the file's whole one: its own entries
                digest = f"{digest} 1/{1 << skipped}"
                image.info[REDUCED_LEVELS] = skipped
        image.info[SOURCE_DIGEST] = digest
        kept = decoded_images.kept(digest)
        if kept is not None:  # decoded before in this process: that image
            return kept
        # the image of the file's bytes, unless libjpeg decodes a reduced one
        early = take_early(digest) if REDUCED_LEVELS not in image.info else None
        if early is not None:  # decoded while the process started (app/textures/early.py)
            early.info[SOURCE_DIGEST] = digest
            image = early
        elif image.format == "PNG" and not decoded_before(image, digest):
            image = _one_idat(image, encoded)  # to be decoded here: in one call
        if decode_later:
            pending = _decoder().submit(_decode_refused, image, digest, budget.limits)
            setattr(image, _PENDING, pending)
            return image
        _decode(image, digest)
        return image
    except Exception as exc:  # Pillow raises many types for data it cannot decode
        raise _refused(exc, budget.limits) from None


def _refused(exc: Exception, limits: Limits) -> RefusedError:
    """What ``open_image`` raises for ``exc``, raised opening or decoding an image (on the
    caller's thread or the decoder pool's): a ``RefusedError`` as it is, Pillow's
    decompression-bomb check as the texture limit the image exceeds, anything else Pillow
    raises for data it cannot decode by its type and message (``early.unreadable``)."""
    if isinstance(exc, RefusedError):
        return exc
    if isinstance(exc, Image.DecompressionBombError):
        side = limits.max_texture_side
        return RefusedError(f"declares more texels than an image of {side} a side")
    return RefusedError(unreadable(exc))


def _one_idat(image: Image.Image, encoded: bytes) -> Image.Image:
    """The PNG ``image`` opened from ``encoded`` again with its image data in one chunk
    (early.single_idat: the decoder takes it in one call, not one per 8 KiB chunk with
    the GIL taken back between), its info carried over; only for an image about to be
    decoded: the join copies and checksums every byte (15 ms for WaterBottle's four)."""
    stream = single_idat(encoded)
    if stream is encoded:
        return image
    joined = open_header(stream)
    joined.info.update(image.info)
    return joined


def _decode(image: Image.Image, digest: str) -> None:
    """``open_image``'s decode: none where the cache records that these bytes decoded
    before (their texels are decoded when first read), else Pillow's, recorded once it
    succeeded (a broken image raises here, before anything is kept)."""
    decoded: list[bool] = []

    def decode() -> list[np.ndarray]:
        image.load()
        decoded.append(True)
        return [np.array(image.size, np.int64)]

    prepared_cache().arrays(DECODES, decode_record(image, digest), decode)
    if decoded:
        decoded_images.keep(digest, image, _image_bytes(image))


def _decode_refused(image: Image.Image, digest: str, limits: Limits) -> None:
    """``_decode`` on the decoder pool, what fails as ``open_image`` refuses it."""
    try:
        _decode(image, digest)
    except Exception as exc:  # Pillow raises many types for data it cannot decode
        raise _refused(exc, limits) from None


def wait_decoded(image: Image.Image) -> None:
    """Wait for ``image``'s decode where ``open_image`` started one (``decode_later``);
    the ``RefusedError`` of a broken image is raised here (and to every later caller)."""
    pending = getattr(image, _PENDING, None)
    if pending is not None:
        waited(pending)


# The attribute of an image that holds its decode on the pool (``decode_later``): a
# Future, its result None or its exception the RefusedError.
_PENDING = "_pbs_decode"
_DECODER: ThreadPoolExecutor | None = None
DECODE_THREADS = 2


def _decoder() -> ThreadPoolExecutor:
    global _DECODER
    if _DECODER is None:
        _DECODER = ThreadPoolExecutor(DECODE_THREADS, thread_name_prefix="pbs-decode")
    return _DECODER


# Guards the colour levels made early (``_EARLY_LEVELS``) and their maker's pool.
_LEVELS_LOCK = threading.Lock()


def _image_bytes(image: Image.Image) -> int:
    return image.width * image.height * len(image.getbands()) * BAND_BYTES.get(image.mode, 1)


def _decoded(image: Image.Image) -> Image.Image:
    """``image`` with its texels decoded, one thread at a time: an image ``open_image``
    returned undecoded decodes on first read, and the prepared maps are built on the
    cache's background thread (``PreparedLevels.prefetch``) while the main thread may read
    the same image (one image can be a glTF material's colour and its metallic-roughness
    map); Pillow's ``load`` is not safe to run twice at once. A decode ``open_image``
    started on its pool is waited for (its ``RefusedError`` raised)."""
    wait_decoded(image)
    with _DECODE_LOCK:
        image.load()
    return image


_DECODE_LOCK = threading.Lock()


def rgb_texels(image: Image.Image) -> np.ndarray:
    """``np.asarray(image.convert("RGB"), np.uint8)``, the same values, made once for an
    image ``open_image`` read (by its file's digest) and shared, read-only, by every map
    built from it (glTF's metallic-roughness image gives the metallic mips and the
    normal/roughness chain), without the copy that ``convert`` makes of an RGB image."""
    digest = image.info.get(SOURCE_DIGEST)
    with _RGB_LOCK:
        kept = _RGB.get(digest) if isinstance(digest, str) else None
    if kept is not None:
        return kept
    decoded = _decoded(image)
    source = decoded if decoded.mode == "RGB" else decoded.convert("RGB")
    view = rgbx_view(source)  # Pillow's own storage where it exports it, else a copy
    texels = view[..., :3] if view is not None else _rgb_bytes(source)
    texels.setflags(write=False)
    if isinstance(digest, str):
        with _RGB_LOCK:
            _RGB[digest] = texels
            while len(_RGB) > _RGB_KEPT:
                _RGB.popitem(last=False)
    return texels


def _rgb_bytes(image: Image.Image) -> np.ndarray:
    """``np.asarray(image, np.uint8)`` of an RGB image, the same bytes, from one call of
    Pillow's raw encoder: ``tobytes`` (which ``np.asarray`` calls) encodes 64 KiB at a
    time, ~190 calls for a 2048^2 image, and joins the pieces into a second copy."""
    size = image.width * image.height * 3
    encoder = getattr(Image, "_getencoder", None)
    if encoder is None or size == 0:  # not this Pillow's internals: its public path
        return np.asarray(image, np.uint8)
    raw = encoder(image.mode, "raw", ("RGB", 0, 1))
    try:
        raw.setimage(image.im, (0, 0, *image.size))
        _, status, data = raw.encode(size)  # the whole image fits: one call, status 1
    finally:
        raw.cleanup()
    if status != 1 or len(data) != size:
        return np.asarray(image, np.uint8)
    return np.frombuffer(data, np.uint8).reshape(image.height, image.width, 3)


# Texels of the last few images ``rgb_texels`` made, by digest (a material's maps ask
# for one image's texels twice, one after the other, on the cache's background thread).
_RGB: OrderedDict[str, np.ndarray] = OrderedDict()
_RGB_KEPT = 2
_RGB_LOCK = threading.Lock()


def read_image(
    path: str | Path, scene_file: str, key: str, budget: Budget | None = None, kind: str = "colour"
) -> Image.Image:
    """A texture file as a Pillow image (``open_image``), or an InputError naming the scene
    key. ``path`` is already confined (``LoadedScene.resolve_file``)."""
    try:
        return open_image(Path(path), budget, kind)
    except RefusedError as exc:
        message = str(exc)
        if not message.startswith(str(path)):
            message = f"{path} {message}"
        raise InputError(scene_file, key, message) from None


def linear_channel(image: Image.Image) -> np.ndarray:
    """The first channel of a non-colour map in [0, 1], float64 (H, W)."""
    if image.mode in ("I;16", "I;16B", "I;16L", "I"):
        data = np.asarray(image, np.float64) / 65535.0
    else:
        data = np.asarray(image.convert("RGB"), np.float64)[..., 0] / 255.0
    return np.clip(data, 0.0, 1.0)


def resample(values: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Bilinear resampling of (H, W[, C]) float data to (h, w) = ``size`` with wrap-around,
    sampling at texel centres (a texture's repeat mode)."""
    h, w = size
    src_h, src_w = values.shape[:2]
    if (src_h, src_w) == (h, w):
        return np.asarray(values, np.float64)
    y = (np.arange(h) + 0.5) * src_h / h - 0.5
    x = (np.arange(w) + 0.5) * src_w / w - 0.5
    return sample_bilinear_wrap(values, x[None, :], y[:, None])


def sample_bilinear_wrap(values: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Bilinear lookup of (H, W[, C]) data at texel coordinates (x, y) (texel centres at
    integers), wrapping around both edges like GL_REPEAT."""
    v = np.asarray(values, np.float64)
    src_h, src_w = v.shape[:2]
    x, y = np.broadcast_arrays(np.asarray(x, np.float64), np.asarray(y, np.float64))
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    xi0, yi0 = x0.astype(np.int64) % src_w, y0.astype(np.int64) % src_h
    xi1, yi1 = (xi0 + 1) % src_w, (yi0 + 1) % src_h
    if v.ndim == 3:
        fx, fy = fx[..., None], fy[..., None]
    top = v[yi0, xi0] * (1 - fx) + v[yi0, xi1] * fx
    bottom = v[yi1, xi0] * (1 - fx) + v[yi1, xi1] * fx
    return top * (1 - fy) + bottom * fy


def normal_roughness_texture(
    normals: np.ndarray | None, roughness: np.ndarray | float, shape: tuple[int, int], method: str
) -> Texture:
    """The RGBA chain of a layer's normals (flat where it has no normal map) and absolute
    perceptual roughness, filtered with ``method`` (app/textures/mips.py). ``lean`` gives
    ``variance``'s chain: lean's own is made only beside its covariance map
    (``lean_normal_maps``), so a map built without one (a bake, a coat) keeps the spread;
    so does ``auto``, which picks lean only beside a covariance map (``auto_normal_filter``)."""
    method = "variance" if method in (LEAN, AUTO) else method
    return _normal_roughness_texture(normals, roughness, shape, method)


def _normal_roughness_texture(
    normals: np.ndarray | None, roughness: np.ndarray | float, shape: tuple[int, int], method: str
) -> Texture:
    """``normal_roughness_texture``, ``lean``'s own chain included."""
    if normals is None:
        normals = np.zeros((*shape, 3))
        normals[..., 2] = 1.0
    n, r = chain_inputs(normals, roughness, "naive" if method in ("none", LEAN) else method)
    return Texture(_chain_levels(lambda y0, y1: (n[y0:y1], r[y0:y1]), n.shape[:2], method))


def _chain_levels(
    source: BandSource,
    shape: tuple[int, int],
    method: str,
    rows_up_float16: bool = False,
    first: int = 0,
) -> list[np.ndarray]:
    """mips.chain_levels with the project's ``none``: level 0 alone, bilinear without mips:
    each sample sees the source normals, aliasing included (what a supersampled reference
    averages). ``first``: levels from there on (mips.chain_levels), ``none`` and ``lean``
    never skip one."""
    if method == "none":
        return chain_levels(source, shape, "naive", 1, rows_up_float16)
    if method == LEAN:  # the spread travels in the slope_covariance map (app/textures/lean.py)
        return lean_chain_levels(source, shape, rows_up_float16)
    return chain_levels(source, shape, method, None, rows_up_float16, first)


def decode_normals(image: Image.Image, scale: float) -> np.ndarray:
    """Unit tangent-space normals from an RGB normal map, x and y scaled by ``scale`` (glTF
    normalTexture.scale) before renormalising."""
    n = decode_normal_map(np.asarray(image.convert("RGB"), np.uint8)).copy()
    if scale != 1.0:
        n[..., :2] *= scale
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return n


def colour_texture(image: Image.Image, first: int = 0) -> Texture:
    """Base colour: sRGB8 with alpha, decoded by the GL (which builds its mips). An image
    ``open_image`` read has its RGBA texels kept in the prepared-texture cache by its
    file's content (with Pillow's version, whose decoder made them): a later load reads
    them instead of decoding the file (``open_image`` then returns it undecoded).

    ``first``: the first level a still frame samples of the whole ``image`` (a map that
    is no JPEG, which libjpeg would have decoded at that level: app/scene/sampled_levels.py).
    A square power-of-two map then keeps that level and the ones below alone, made here as a
    DCT-scaled map's mips are (``mips.srgb_box_levels``: a 2x2 box in linear light, within
    a step of the GL's), so its finer levels are neither kept nor uploaded."""

    def rgba() -> list[np.ndarray]:
        return [np.asarray(_decoded(image).convert("RGBA"), np.uint8)]

    digest = image.info.get(SOURCE_DIGEST)
    if not isinstance(digest, str):
        return Texture(rgba(), srgb=True)
    key = f"{image.mode}|{image.size}|{PIL.__version__}|{digest}"

    def rows_up_into(texels: np.ndarray) -> None:
        # Kept rows bottom first, as the GL takes them: level 0 is a view of the entry read
        # backwards, and the upload's rows-up copy of it is the entry itself. Pillow's raw
        # encoder writes the rows in that order (orientation -1): one copy of the texels.
        decoded = _decoded(image)
        if texels.shape != (decoded.height, decoded.width, 4):
            raise ValueError(f"{decoded.size} texels decoded for a {image.size} image")
        if decoded.mode == "RGB":
            # An RGB image's texels are stored 4 bytes each; a decoder's 4th byte is 255,
            # so the raw "RGBX" bytes are convert("RGBA")'s, without the converted copy.
            # Checked, since an image made otherwise may hold another 4th byte. Copied
            # rows bottom first from Pillow's storage where it is one view (pillow_view),
            # else by the raw encoder (64 KiB at a time, then joined: a second copy).
            view = rgbx_view(decoded)
            if view is not None:
                np.copyto(texels, view[::-1])
            else:
                raw = decoded.tobytes("raw", "RGBX", 0, -1)
                texels.reshape(-1)[:] = np.frombuffer(raw, np.uint8)
            if texels.size and texels[..., 3].min() == 255:
                return
        converted = decoded.convert("RGBA")
        texels.reshape(-1)[:] = np.frombuffer(converted.tobytes("raw", "RGBA", 0, -1), np.uint8)

    def rows_up() -> list[np.ndarray]:
        texels = np.empty((image.height, image.width, 4), np.uint8)
        rows_up_into(texels)
        return [texels]

    square = _square_power_of_two(image)
    skipped = first if square and not image.info.get(REDUCED_LEVELS) else 0
    if square and (image.info.get(REDUCED_LEVELS) or skipped):
        # A DCT-scaled level is not the GL's level n anyway, and a whole map's level n is
        # made here: the mips too (mips.srgb_box_levels), without the GL's blit (compiled
        # once a process).
        finest: Future = Future()  # the first level kept, handed over before the others

        def made() -> list[np.ndarray]:
            if not skipped:
                texels = rows_up()[0]
                finest.set_result(texels[::-1])
                return srgb_box_levels(texels)
            kept = _colour_levels_from_one(image)[skipped - 1 :]
            finest.set_result(kept[0][::-1])
            return kept

        parts = (_prepared_version(), key) + ((("from level", skipped),) if skipped else ())

        def levels() -> list[np.ndarray]:
            try:
                entry = prepared_cache().arrays("colour rgba8 rows up mips", parts, made)
            except BaseException as exc:
                if not finest.done():
                    finest.set_exception(exc)
                raise
            made_levels = [level[::-1] for level in entry]
            if not finest.done():  # read from the cache: no level handed over
                finest.set_result(made_levels[0])
            return made_levels

        future = _colour_maker().submit(levels)
        return Texture(PendingLevels(future, finest), srgb=True, source_key=key)
    layout = [((image.height, image.width, 4), np.uint8)]  # the texels of its header's size
    fill = lambda into: rows_up_into(*into)  # noqa: E731
    (texels,) = prepared_cache().filled(
        "colour rgba8 rows up", (_prepared_version(), key), layout, fill
    )
    return Texture([texels[::-1]], srgb=True, source_key=key)


def start_colour_levels(image: Image.Image) -> None:
    """Make the levels of colour map ``image`` from level 1 on, as ``colour_texture``
    keeps them, on this thread, before the reader asks for them: a still render's early
    decode of a colour map that is no JPEG (app/scene/early_images.py) calls this once the
    image is decoded, while the main thread is still importing and framing the scene, so
    that ``colour_texture`` finds them made instead of making them while the scene's
    exposure waits for the base colour. Nothing where ``image`` (an image ``open_image``
    reads by the digest of its bytes) is no square power-of-two map or its levels are
    being made already. ``first`` is not known yet: level 1 is where a still frame's
    levels start unless it samples the map's finest one, and then these go unused (a
    third of the map's RGBA bytes, made on the core the imports leave idle)."""
    digest = image.info.get(SOURCE_DIGEST)
    if not isinstance(digest, str) or not _square_power_of_two(image) or image.width < 2:
        return
    done: Future = Future()
    with _LEVELS_LOCK:
        if digest in _EARLY_LEVELS:
            return
        _EARLY_LEVELS[digest] = done
    try:
        done.set_result(srgb_box_levels(_rows_up_source(image))[1:])
    except BaseException as exc:  # the reader makes them again and meets what failed
        done.set_exception(exc)


def _colour_levels_from_one(image: Image.Image) -> list[np.ndarray]:
    """``srgb_box_levels`` of colour map ``image`` from level 1 on, rows bottom first:
    those ``start_colour_levels`` made of it (waited for where they are being made),
    once, else made here."""
    digest = image.info.get(SOURCE_DIGEST)
    with _LEVELS_LOCK:
        early = _EARLY_LEVELS.pop(digest, None) if isinstance(digest, str) else None
    before_waiting(early)
    if early is not None and early.exception() is None:
        return early.result()
    return srgb_box_levels(_rows_up_source(image))[1:]


# Levels from 1 on of colour maps decoded early (``start_colour_levels``), by the digest of
# their image's bytes, until ``colour_texture`` takes them.
_EARLY_LEVELS: dict[str, Future] = {}


def _square_power_of_two(image: Image.Image) -> bool:
    """Whether ``image`` is square with a power-of-two side: a map whose levels are made
    here on the CPU (``colour_texture``'s 2x2 boxes halve it exactly)."""
    side = image.width
    return image.height == side and side & (side - 1) == 0


def _stored_rgbx(image: Image.Image) -> np.ndarray | None:
    """``image`` decoded, its storage as an (H, W, 4) view where it is an RGB image whose
    storage Pillow exports in one piece (``pillow_view.rgbx_view``: the 4th byte its
    padding); else None."""
    decoded = _decoded(image)
    return rgbx_view(decoded) if decoded.mode == "RGB" else None


def _rows_up_source(image: Image.Image) -> np.ndarray:
    """A colour map's RGBA texels rows bottom first, to make levels from that are kept
    without it: a view of Pillow's storage read backwards where the image is RGB, stored
    so and its padding byte 255 (what ``convert("RGBA")`` gives it), else a copy."""
    view = _stored_rgbx(image)
    if view is not None and (view.size == 0 or view[..., 3].min() == 255):
        return view[::-1]
    return np.asarray(_decoded(image).convert("RGBA"), np.uint8)[::-1]


class PendingLevels(Sequence[np.ndarray]):
    """A colour map's levels being made on a thread of their own (``colour_texture``: its
    decode waited for, its mips made or its entry read), read when first indexed: the
    thread that reads the material goes on with the parts, the framing and the GL while
    they are made. A broken image's ``RefusedError`` is raised to whoever reads them (a
    glTF file reports it, by its key, before: app/scene/gltf.py ``_decodes_checked``).
    ``first``, where given: level 0 alone, set as soon as it is at hand (before the mips
    are made), which ``levels[0]`` waits for instead (the exposure meter reads level 0
    while the mips are still being made)."""

    def __init__(self, future: Future, first: Future | None = None) -> None:
        self._future = future
        self._first = first

    def __getitem__(self, index):  # type: ignore[override]  # an int or a slice, as a list's
        if index == 0 and self._first is not None and not self._future.done():
            return waited(self._first)
        return waited(self._future)[index]

    def __len__(self) -> int:
        return len(waited(self._future))


_COLOUR_MAKER: ThreadPoolExecutor | None = None


def _colour_maker() -> ThreadPoolExecutor:
    global _COLOUR_MAKER
    with _LEVELS_LOCK:
        if _COLOUR_MAKER is None:
            _COLOUR_MAKER = ThreadPoolExecutor(1, thread_name_prefix="pbs-colour-levels")
    return _COLOUR_MAKER


def scalar_texture(values: np.ndarray) -> Texture:
    """A single-channel non-colour map with box-filtered mips (mips.box_mips), never the GL's."""
    return Texture([level[..., None] for level in box_mips(values)])


def direction_texture(image: Image.Image) -> Texture:
    """An anisotropy direction map (glTF KHR_materials_anisotropy's anisotropyTexture RG):
    the direction 2 rg - 1 in the tangent frame (t, b), stored decoded (float16, the
    G-buffer pass renormalises it) with box-filtered mips. Averaging directions is what
    the specification's sampler does too: opposite directions (the same axis of
    anisotropy) cancel in the mips, and a texel of length 0 reads as t itself."""
    rg = np.asarray(image.convert("RGB"), np.float64)[..., :2] / 255.0
    return Texture(box_mips(2.0 * rg - 1.0))


def normal_roughness_chain(
    normals: np.ndarray | None, factor: float, values: np.ndarray | None, normal_filter: str
) -> Texture:
    """A layer's one normal/roughness chain: ``normals`` (decoded; None: flat) with the
    roughness ``factor`` times the roughness map's ``values`` where there is one (else the
    factor alone), resampled to the normal map's size when both are given. ``lean`` is
    built as ``variance`` here (``normal_roughness_texture``): an OBJ's material, made
    without the covariance map ``lean_normal_maps`` adds, keeps the isotropic spread."""
    roughness, shape = _chain_roughness(normals, factor, values)
    return normal_roughness_texture(normals, roughness, shape, normal_filter)


def _chain_roughness(
    normals: np.ndarray | None, factor: float, values: np.ndarray | None
) -> tuple[np.ndarray | float, tuple[int, int]]:
    """``normal_roughness_chain``'s roughness per texel (or one value) and the chain's size."""
    roughness: np.ndarray | float = factor
    if values is not None:
        if normals is not None:  # the chain is built at the normal map's size
            values = resample(values, normals.shape[:2])
        roughness = factor * values
    shape = normals.shape[:2] if normals is not None else np.shape(roughness)
    return roughness, shape


def lean_normal_maps(
    normals: np.ndarray, factor: float, values: np.ndarray | None
) -> dict[str, Texture]:
    """``render.normal_filter = "lean"`` (Olano & Baker 2010): the ``normal_roughness``
    chain of the mean slopes with the material's own roughness, and the
    ``slope_covariance`` map of the same normals (app/textures/lean.py); arguments as
    ``normal_roughness_chain``'s."""
    roughness, shape = _chain_roughness(normals, factor, values)
    return {
        "normal_roughness": _normal_roughness_texture(normals, roughness, shape, LEAN),
        "slope_covariance": slope_covariance_texture(normals),
    }


def coat_normal_texture(image: Image.Image, scale: float) -> Texture:
    """A clear coat's own normal map (RTR4 §9.12) with its ``scale``. The coat's roughness
    is a material constant (the G-buffer has no channel for it per pixel): its mips carry
    the normals alone, renormalised on sampling."""
    coat = decode_normals(image, scale)
    return normal_roughness_texture(coat, 0.0, coat.shape[:2], "naive")


def _prepared_version() -> str:
    """The code version of what this module prepares in numpy (app/textures/versions.py)."""
    return version("maps")


def _image_part(image: Image.Image | None) -> tuple:
    """An image's content as a cache key part: its mode and size, and the digest of the
    file it was decoded from (with the decoder's version) where open_image read it, else
    its decoded bytes."""
    if image is None:
        return (None,)
    digest = image.info.get(SOURCE_DIGEST)
    if isinstance(digest, str):
        return (image.mode, image.size, "encoded", PIL.__version__, digest)
    return (image.mode, image.size, image.tobytes())


def normal_roughness_map(
    normal_image: Image.Image | None,
    scale: float,
    factor: float,
    roughness_image: Image.Image | None,
    normal_filter: str,
    first: int = 0,
) -> Texture:
    """A glTF material's normal/roughness chain: ``decode_normals`` of ``normal_image``
    (None: flat) with ``scale``, and roughness ``factor`` times the green channel of
    ``roughness_image`` (glTF metallicRoughnessTexture; None: the factor alone), through
    ``normal_roughness_chain``; kept in the prepared-texture cache by the images' content
    and the parameters. ``first``: its levels from ``first`` on alone, the same bits as the
    whole chain's (a still frame samples no finer one: app/scene/sampled_levels.py);
    ``none`` and ``lean`` filters keep every level."""
    first = first if normal_filter not in ("none", LEAN) else 0

    def build(rows_up_float16: bool = False) -> list[np.ndarray]:
        return _map_chain_levels(
            normal_image, scale, factor, roughness_image, normal_filter, rows_up_float16, first
        )

    parts = (
        _prepared_version(),
        _image_part(normal_image),
        float(scale),
        float(factor),
        _image_part(roughness_image),
        normal_filter,
        *((("from level", first),) if first else ()),
    )
    sized = normal_image if normal_image is not None else roughness_image
    assert sized is not None, "a chain needs a normal or a roughness map"
    layout = (sized.height >> first, sized.width >> first, 4, normal_filter == "none")
    upload = lambda: build(rows_up_float16=True)  # noqa: E731
    gl_source = None
    if (
        normal_filter == "variance"
        and normal_image is not None
        and (roughness_image is None or roughness_image.size == normal_image.size)
    ):
        gl_source = ChainSource(normal_image, roughness_image, float(scale), float(factor), first)
    levels = PreparedLevels("normal_roughness", parts, build, layout, upload, gl_source)
    if gl_source is not None:  # drawn at a wait of the reader where a render asks (app/cli.py)
        offer(GL_CHAIN, levels)
    texture = Texture(levels)
    texture.with_factor = lambda other: normal_roughness_map(
        normal_image, scale, other, roughness_image, normal_filter, first
    )
    return texture


def _map_chain_levels(
    normal_image: Image.Image | None,
    scale: float,
    factor: float,
    roughness_image: Image.Image | None,
    normal_filter: str,
    rows_up_float16: bool = False,
    first: int = 0,
) -> list[np.ndarray]:
    """``normal_roughness_chain(decode_normals(normal_image, scale), factor, green / 255,
    normal_filter).levels`` (``rows_up_float16``: as the GL takes them, mips.chain_levels),
    bit for bit, with the images decoded to float64 a band of
    rows at a time as the chain reads them (mips.chain_levels) instead of whole: the
    8-bit texels are all that is held. The inputs need no check: decoded normals are unit
    and a glTF roughness factor lies in [0, 1] (app/scene/gltf.py)."""
    rgb = None
    if normal_image is not None:
        rgb = rgb_texels(normal_image)
    green = None
    if roughness_image is not None:
        green = rgb_texels(roughness_image)[..., 1]
    shape = rgb.shape[:2] if rgb is not None else green.shape  # type: ignore[union-attr]
    values = None
    if green is not None and green.shape != shape:  # resampled to the normal map's size
        values = factor * resample(green / 255.0, shape)

    def source(y0: int, y1: int) -> tuple[np.ndarray, np.ndarray]:
        if rgb is None:
            n = np.zeros((y1 - y0, shape[1], 3))
            n[..., 2] = 1.0
        else:  # as planes: the moments read one component at a time (mips.py)
            n = decode_normal_map(rgb[y0:y1], planes=True)
            if scale != 1.0:
                n[..., :2] *= scale
                n /= np.linalg.norm(n, axis=-1, keepdims=True)
        if values is not None:
            r = values[y0:y1]
        elif green is not None:
            r = factor * (green[y0:y1].astype(np.float64) / 255.0)
        else:
            r = np.full((y1 - y0, shape[1]), float(factor))
        return n, r

    return _chain_levels(source, shape, normal_filter, rows_up_float16, first)


def slope_covariance_texture(normals: np.ndarray) -> Texture:
    """The ``slope_covariance`` map of decoded unit normals (H, W, 3): per level the
    covariance of the slopes under each texel (app/textures/lean.py), beside the ``lean``
    normal/roughness chain of the same normals."""
    return Texture(covariance_levels(normals, normals.shape[:2]))


def slope_covariance_map(normal_image: Image.Image, scale: float) -> Texture:
    """``slope_covariance_texture`` of a glTF normal map (``decode_normals`` with ``scale``),
    the normals decoded a band of rows at a time, kept in the prepared-texture cache by the
    image's content."""

    def build(rows_up_float16: bool = False) -> list[np.ndarray]:
        rgb = np.asarray(_decoded(normal_image).convert("RGB"), np.uint8)

        def source(y0: int, y1: int) -> tuple[np.ndarray, None]:
            n = decode_normal_map(rgb[y0:y1])
            if scale != 1.0:
                n[..., :2] *= scale
                n /= np.linalg.norm(n, axis=-1, keepdims=True)
            return n, None

        return covariance_levels(source, rgb.shape[:2], rows_up_float16)

    parts = (_prepared_version(), _image_part(normal_image), float(scale))
    layout = (normal_image.height, normal_image.width, 3, False)
    upload = lambda: build(rows_up_float16=True)  # noqa: E731
    return Texture(PreparedLevels("slope_covariance", parts, build, layout, upload))


def auto_normal_filter(normal_image: Image.Image, scale: float) -> str:
    """What ``render.normal_filter = "auto"`` builds for a glTF normal map (``lean`` or
    ``variance``: app/textures/lean.py ``auto_filter``), its sampled spread kept in the
    prepared-texture cache by the image's content, so that a render whose maps are kept
    decodes no image to choose."""

    def build() -> list[np.ndarray]:
        return [spread_levels(rgb_texels(normal_image), scale)]

    parts = (_prepared_version(), _image_part(normal_image), float(scale))
    (covariance,) = prepared_cache().arrays("normal spread", parts, build)
    return LEAN if directional_spread(covariance) else "variance"


def channel_texture(image: Image.Image, channel: int, first: int = 0) -> Texture:
    """``scalar_texture`` of one 8-bit RGB channel of ``image`` in [0, 1] (a glTF metallic
    (B) or occlusion (R) map), kept in the prepared-texture cache by the image's content;
    ``first``: its levels from there on alone (``normal_roughness_map``'s)."""

    def build(rows_up_float16: bool = False) -> list[np.ndarray]:
        # scalar_texture(rgb[..., channel] / 255.0).levels, made from the 8-bit texels
        # (mips.unorm8_box_levels: box_levels' bits; rows_up_float16 as there)
        return unorm8_box_levels(rgb_texels(image)[..., channel], rows_up_float16, first)

    parts = (_prepared_version(), _image_part(image), int(channel))
    parts += (("from level", first),) if first else ()
    layout = (image.height >> first, image.width >> first, 1, False)
    upload = lambda: build(rows_up_float16=True)  # noqa: E731
    return Texture(PreparedLevels("channel", parts, build, layout, upload))
