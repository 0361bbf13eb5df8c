"""Images decoded before the reader asks for them: a still render starts decoding a glTF
file's whole-decoded images while it is still importing the scene's modules
(app/scene/early_images.py), and ``maps.open_image`` takes such an image, by its bytes'
digest, instead of decoding them again.

Only the standard library is imported with this module (Pillow and the prepared-texture
cache when an image is decoded), so that the decode starts on the core the imports leave
idle instead of waiting for them. Nothing is reported from here: an image that is refused
or fails to decode is simply not kept, and the reader opens, checks and decodes it as
always, naming it by its key."""

from __future__ import annotations

import hashlib
import io
import re
import struct
import threading
import warnings
import weakref
import zlib
from concurrent.futures import Future
from typing import TYPE_CHECKING

from app.waiting import before_waiting

if TYPE_CHECKING:
    from app.untrusted.budget import Budget

# The image formats a texture may be in: what glTF 2.0 allows (PNG, JPEG) and what OBJ
# exporters write. Pillow's other readers (EPS runs Ghostscript, PSD, ICNS, ...) are never
# asked to parse an input.
IMAGE_FORMATS = ("PNG", "JPEG", "BMP", "TGA", "TIFF", "WEBP")
# Bytes per band of a decoded Pillow image by mode (what ``load`` allocates per texel).
BAND_BYTES = {"I;16": 2, "I;16L": 2, "I;16B": 2, "I;16N": 2, "I": 4, "F": 4}

# Images decoding or decoded early, by their bytes' SHA-256, until the reader takes them;
# the digests the reader asked for, so that an early decode it did not wait for (the
# reader came first) is not made, nor kept, afterwards.
_EARLY: dict[str, Future] = {}
_TAKEN: set[str] = set()
_LOCK = threading.Lock()  # both, and the early decodes' shared budget
# Every image decoded early, by digest, for as long as something holds it (taken or not).
_DECODED: weakref.WeakValueDictionary = weakref.WeakValueDictionary()


def decode_early(data: bytes, budget: Budget) -> str | None:
    """Decode the image ``data`` holds on this thread, for ``take``: not where it is no
    image of ``IMAGE_FORMATS``, where its texels do not fit ``budget`` (charged as
    ``maps.open_image`` charges an image: the early decodes of one render share one), or
    where the prepared-texture cache records that these bytes decoded before (a warm
    render reads its prepared maps and decodes no whole image: ``maps.open_image``).
    Returns the bytes' digest where it decoded them (``peek`` then has the image)."""

    digest = hashlib.sha256(data).hexdigest()
    try:
        image = open_header(data)
        with _LOCK:  # the early threads charge one budget
            if digest in _TAKEN:
                return
            charge_decode(image, budget, None)
    except Exception:  # not an image pbs reads, or past the budget (a RefusedError)
        return
    if decoded_before(image, digest):
        return
    try:
        encoded = single_idat(data)  # to be decoded: its image data in one chunk
        if encoded is not data:
            image = open_header(encoded)
    except Exception:  # left to the reader, which names what is wrong
        return
    done: Future = Future()
    with _LOCK:
        if digest in _EARLY or digest in _TAKEN:
            return
        _EARLY[digest] = done
    try:
        image.load()
    except Exception as exc:  # the reader decodes it again and names it
        done.set_exception(exc)
        return None
    _DECODED[digest] = image
    done.set_result(image)
    return digest


# The prepared-texture cache's record that an image's bytes decoded (maps._decode writes
# it once a decode succeeds): its kind; its parts are ``decode_record``'s.
DECODES = "decodes"


def decode_record(image, digest: str) -> tuple:  # image: PIL.Image.Image
    """The key parts of the record that the bytes of SHA-256 ``digest`` decode as
    ``image``'s format under this Pillow."""
    import PIL

    return (PIL.__version__, image.format, digest)


def decoded_before(image, digest: str) -> bool:  # image: PIL.Image.Image
    """Whether the prepared-texture cache records that the bytes of SHA-256 ``digest``
    decoded before as ``image``'s format: such an image is not decoded until its texels
    are read (a warm render reads its prepared maps instead). Before the cache's module is
    imported its process's cache holds nothing in memory, and the disk is asked with the
    standard library alone (app/textures/cache_keys.py): an early decode does not wait for
    numpy's import on the main thread."""
    import sys

    if "app.textures.cache" not in sys.modules:
        from app.textures.cache_keys import held_on_disk

        return held_on_disk(DECODES, decode_record(image, digest))
    from app.textures.cache import prepared_cache

    return prepared_cache().holds(DECODES, decode_record(image, digest))


def unreadable(exc: BaseException) -> str:
    """Why an image is refused, for the one line that names its file and key: Pillow's
    exception type and message ("OSError: image file is truncated"), without the object
    reprs some messages carry (a memory address), and at most ``_REASON_CHARS`` long."""
    text = " ".join(re.sub(r"<[^<>]*>", "", str(exc)).split())
    reason = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    if len(reason) > _REASON_CHARS:
        reason = reason[: _REASON_CHARS - 1] + "…"
    return f"is not an image pbs reads ({reason})"


_REASON_CHARS = 100


def open_header(data: bytes):  # -> PIL.ImageFile.ImageFile
    """The image ``data`` holds, its header read and nothing decoded: only
    ``IMAGE_FORMATS`` parsed, Pillow's own size warnings kept off stderr (``charge_decode``
    is what refuses an oversized image), its decoder handed the whole stream at once
    (``whole_reads``). Pillow's error where ``data`` is no such image."""
    from PIL import Image

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)
        image = Image.open(io.BytesIO(data), formats=IMAGE_FORMATS)
    whole_reads(image, len(data))
    return image


def charge_decode(image, budget: Budget, kind: str | None) -> None:
    """Check the size ``image``'s header declares and charge its decode to ``budget``,
    before a texel is decoded: at most the limits' side, the map of ``kind`` (colour,
    scalar, normal, direction; None: the caller charges the map) and the decoded texels'
    bytes (Pillow's storage: 4 bytes a texel at least). ``RefusedError`` past either."""
    from app.untrusted import RefusedError

    width, height = image.size
    if width <= 0 or height <= 0:
        raise RefusedError(f"declares a {width}x{height} image")
    bands = len(image.getbands()) * BAND_BYTES.get(image.mode, 1)
    budget.texture(width, height, kind, "the image")
    budget.charge(width * height * max(bands, 4), "byte", "its decoded texels")


def whole_reads(image, size: int) -> None:  # image: PIL.ImageFile.ImageFile
    """Have Pillow's ``load`` hand the decoder the whole encoded image (``size`` bytes) in
    one call instead of 64 KiB at a time: the decoder lets go of the GIL for each call, so
    a decode on a thread of its own then runs without taking the GIL back 50 times from a
    thread that holds it (the imports, the main thread's work): the helmet's
    metallic-roughness JPEG decoded beside a busy thread in 0.11 s instead of 0.21. The
    same decoder on the same bytes: the same texels."""
    image.decodermaxblock = max(getattr(image, "decodermaxblock", 0), size)


def peek(digest: str):  # -> PIL.Image.Image | None
    """The image of the bytes with SHA-256 ``digest`` decoded early, where its decode is
    done and the reader has not taken it yet; else None. Not taken by this."""
    with _LOCK:
        done = _EARLY.get(digest)
    if done is None or not done.done() or done.exception() is not None:
        return None
    return done.result()


def decoded(digest: str):  # -> PIL.Image.Image | None
    """The image of the bytes with SHA-256 ``digest`` decoded early, whether or not the
    reader has taken it, while something holds it; else None."""
    return _DECODED.get(digest)


def take(digest: str):  # -> PIL.Image.Image | None
    """The image of the bytes with SHA-256 ``digest`` decoded early (waited for where its
    decode is still running), once; None where there is none or its decode failed (and no
    early decode of those bytes starts after this)."""
    with _LOCK:
        done = _EARLY.pop(digest, None)
        _TAKEN.add(digest)
    before_waiting(done)
    if done is None or done.exception() is not None:
        return None
    return done.result()


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# More IDAT chunks than this are left as they are (the decoder meets them one by one): a
# hostile file's millions of empty chunks would cost a loop and a list of that length.
MAX_IDAT_CHUNKS = 1 << 16
# Image data past this many bytes is left in its chunks too: the join holds two copies of
# it (the stream, then the file around it) beside the file's own bytes.
MAX_JOINED_BYTES = 256 << 20


def single_idat(data: bytes) -> bytes:
    """A PNG's bytes with its image data in one IDAT chunk, the same image: the bytes
    themselves where they are no PNG, hold one IDAT already, more than ``MAX_IDAT_CHUNKS``
    or ``MAX_JOINED_BYTES`` of image data, or are not laid out as the PNG specification
    lays a file out (the decoder then meets them as they are). The chunks after IEND are
    kept.

    PNG splits its one zlib stream of image data over IDAT chunks, commonly of 8 KiB
    (libpng's default): hundreds in a 2048^2 map (docs/performance.md). Pillow
    hands its decoder one chunk per call, and takes the GIL back between calls, so a
    decode on a thread of its own waited for the GIL at every chunk while another thread
    ran Python (the imports, the main thread's work). The stream's bytes joined into one
    chunk (its CRC-32 computed anew, chunk type and data as the specification defines
    it) decode in one call: the same texels (tests/test_early_images.py).

    The CRC is computed over the joined stream in one call, not chunk by chunk: CPython's
    ``zlib.crc32`` lets go of the GIL for every buffer past 5 KiB, so a checksum per 8 KiB
    chunk took the GIL back hundreds of times, a switch interval each beside a thread
    running Python (docs/performance.md). The stream joined first costs a second copy of
    it, which ``MAX_JOINED_BYTES`` bounds."""
    if not data.startswith(PNG_SIGNATURE):
        return data
    view = memoryview(data)
    first = end_of_idat = None  # the offsets of the first IDAT chunk and past the last
    pieces: list[tuple[int, int]] = []  # each IDAT chunk's data: (offset, length)
    at = len(PNG_SIGNATURE)
    while at < len(data):
        if at + 12 > len(data) or len(pieces) > MAX_IDAT_CHUNKS:
            return data
        length, kind = struct.unpack_from(">I4s", data, at)
        end = at + 12 + length
        if end > len(data):
            return data
        if kind == b"IDAT":
            if end_of_idat is not None and end_of_idat != at:  # image data after another chunk
                return data
            first = at if first is None else first
            pieces.append((at + 8, length))
            end_of_idat = end
        elif kind == b"IEND":
            break  # what follows is no part of the image: kept as it is
        at = end
    if len(pieces) < 2 or first is None or end_of_idat is None:
        return data
    if sum(length for _, length in pieces) > MAX_JOINED_BYTES:
        return data
    stream = b"".join([view[offset : offset + length] for offset, length in pieces])
    crc = zlib.crc32(stream, zlib.crc32(b"IDAT"))  # once: see the docstring
    return b"".join([
        view[:first], struct.pack(">I", len(stream)), b"IDAT", stream,
        struct.pack(">I", crc), view[end_of_idat:],
    ])  # fmt: skip
