"""Files a mesh file names, checked before the glTF reader or trimesh reads it.

trimesh swallows a missing texture: a glTF whose base colour image is gone loads with
``baseColorTexture = None`` (it logs the error and the model renders white), and an OBJ
whose MTL is gone gets a grey default material with a white image. A glTF with an
extension the project does not decode would load as geometry it cannot draw. So the
references are read here from the files themselves, and each problem comes back as one
sentence for an ``InputError``. Every reference is confined first (app/untrusted/files.py):
one that resolves outside the allowed folders is refused with the same sentence whether
its target exists or not, and nothing outside is ever opened.

- glTF / GLB (an opened ``GltfDocument``): every ``buffers[i].uri`` and ``images[i].uri``
  that is not a ``data:`` URI must name a plain file (relative to the glTF,
  percent-decoded as glTF 2.0 says); an image's header must open as a format pbs reads.
  Every name in ``extensionsRequired`` must be one pbs reads (``extension_read``).
- OBJ: every ``mtllib`` must name a plain text file, and every map in it that the project
  reads (``MTL_MAP_KEYWORDS``: ``map_Kd``, ``map_Pr``, ``map_Pm``, ``norm``, ``map_Ke``,
  ``map_d``) an image, relative to the MTL's folder.
"""

from __future__ import annotations

import io
import re
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, features

from app.scene.gltf import meshopt_available
from app.scene.gltf_document import GltfDocument
from app.scene.gltf_extensions import SUPPORTED as MATERIAL_EXTENSIONS
from app.textures.early import IMAGE_FORMATS, unreadable
from app.untrusted import RefusedError, files
from app.untrusted.policy import InputPolicy

# glTF extensions a file may *require* (docs/scene-format.md, "Mesh files"): those the
# reader (app/scene/gltf.py) decodes, the material extensions it hands to
# app/scene/gltf_extensions.py, and KHR_lights_punctual (lights are optional to draw).
SUPPORTED_EXTENSIONS: frozenset[str] = frozenset(
    {
        "KHR_draco_mesh_compression",
        "KHR_mesh_quantization",
        "KHR_texture_transform",
        "KHR_materials_emissive_strength",
        "KHR_lights_punctual",
        "KHR_materials_variants",
        *MATERIAL_EXTENSIONS,
    }
)
# And those whose decoder is optional: asked only when a file requires one, so that no
# render imports meshoptimizer or probes Pillow's codecs for files that need neither.
OPTIONAL_EXTENSIONS: dict[str, Callable[[], bool]] = {
    "EXT_texture_webp": lambda: features.check("webp"),
    "EXT_meshopt_compression": meshopt_available,
}


def extension_read(name: str) -> bool:
    """Whether pbs reads a file that requires the glTF extension ``name``."""
    return name in SUPPORTED_EXTENSIONS or (
        name in OPTIONAL_EXTENSIONS and OPTIONAL_EXTENSIONS[name]()
    )


# Hints for required extensions users meet most (a Draco .glb used to draw nothing).
_HINTS = {
    "EXT_meshopt_compression": "meshoptimizer-compressed geometry; "
    "pip install 'pbs-lab[meshopt]' to read it",
}


def _unreadable(file: Path, image: bool, policy: InputPolicy) -> str | None:
    """Why ``file`` (confined already) cannot be used: not a plain file, past the size
    limit, or (``image``) a header that is not an image pbs reads; None where it can."""
    try:
        if not image:
            files.check_readable(file, policy.limits.max_file_bytes)
        else:
            with (
                files.open_regular(file, policy.limits.max_file_bytes) as (fd, _),
                open(fd, "rb", closefd=False) as stream,
                warnings.catch_warnings(),
            ):
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)
                with Image.open(stream, formats=IMAGE_FORMATS):
                    pass
    except RefusedError as exc:
        return str(exc)
    except Exception as exc:  # Pillow raises many types for data it cannot decode
        return f"{file}: {unreadable(exc)}"
    return None


def _ktx2_only(doc: GltfDocument) -> set[int]:
    """The images only KHR_texture_basisu names (KTX2, never decoded: the reader takes
    the texture's fallback ``source``), whose headers are not checked."""
    basisu, read = set(), set()
    for tex in doc.textures or []:
        extensions = tex.extensions or {}
        ktx2 = extensions.get("KHR_texture_basisu")
        if isinstance(ktx2, dict) and isinstance(ktx2.get("source"), int):
            basisu.add(ktx2["source"])
        webp = extensions.get("EXT_texture_webp")
        if isinstance(webp, dict) and isinstance(webp.get("source"), int):
            read.add(webp["source"])
        if tex.source is not None:
            read.add(tex.source)
    return basisu - read


def gltf_problem(doc: GltfDocument, path: Path, policy: InputPolicy) -> str | None:
    """The first problem with a glTF/GLB's required extensions or referenced files."""
    for name in doc.extensionsRequired or []:
        if not extension_read(name):
            what = f" ({_HINTS[name]})" if name in _HINTS else ""
            return (
                f"{path} requires the glTF extension {name}{what}, which pbs does not "
                "read; export the file without it"
            )
    ktx2 = _ktx2_only(doc)
    for table, image in (("buffers", False), ("images", True)):
        for i, entry in enumerate(getattr(doc, table) or []):
            uri = entry.uri
            if uri is None or uri.startswith("data:") or (image and i in ktx2):
                continue
            try:
                file = files.confine_uri(uri, path, policy)
            except RefusedError as exc:
                return f"{path}: {table}[{i}].uri: {exc}"
            why = _unreadable(file, image, policy)
            if why is not None:
                return f"{path}: {table}[{i}].uri '{uri}': {why}"
    return None


# The MTL statements naming a map the project reads (lower-case; docs/scene-format.md,
# "Mesh files"): base colour, the PBR extension's roughness, metallic and normal maps,
# emission and dissolve. ``bump`` / ``map_Bump`` are not among them: most exporters write
# a height map there, which the project does not turn into normals.
MTL_MAP_KEYWORDS = ("map_kd", "map_pr", "map_pm", "norm", "map_ke", "map_d")

# The options a map statement may put before its file name, and how many words each
# takes (Wavefront's MTL specification; -o, -s and -t take one to three numbers, -mm two).
_MTL_OPTIONS = {
    "-blendu": 1, "-blendv": 1, "-bm": 1, "-boost": 1, "-cc": 1, "-clamp": 1,
    "-imfchan": 1, "-texres": 1, "-type": 1, "-mm": 2, "-o": 3, "-s": 3, "-t": 3,
}  # fmt: skip


@dataclass(frozen=True)
class MtlMap:
    """One map statement of an MTL material: the keyword as written (``map_Pr``), the
    file name as written, the file (relative to the MTL's folder, confined; None where
    the policy refuses it, with ``refused`` saying why) and the options."""

    keyword: str
    name: str
    file: Path | None
    options: dict[str, tuple[str, ...]]
    refused: str | None = None


def _is_number(word: str) -> bool:
    try:
        float(word)
    except ValueError:
        return False
    return True


def parse_map_statement(rest: str) -> tuple[dict[str, tuple[str, ...]], str]:
    """(options, file name) of the text after a map keyword: options first, each with
    its words (up to ``_MTL_OPTIONS``'s count; -o, -s, -t stop at the first word that is
    not a number), then the file name, the rest of the line (spaces inside it kept)."""
    options: dict[str, tuple[str, ...]] = {}
    words = list(re.finditer(r"\S+", rest))
    i = 0
    while i < len(words) and words[i].group().lower() in _MTL_OPTIONS:
        option = words[i].group().lower()
        count = _MTL_OPTIONS[option]
        numeric = option in ("-mm", "-o", "-s", "-t")
        taken: list[str] = []
        i += 1
        # Leave at least one word for the file name.
        while len(taken) < count and i < len(words) - 1:
            word = words[i].group()
            if numeric and taken and not _is_number(word):
                break
            taken.append(word)
            i += 1
        options[option] = tuple(taken)
    name = rest[words[i].start() :].strip() if i < len(words) else ""
    return options, name


def mtl_materials(mtl: Path, text: str, policy: InputPolicy) -> dict[str, dict[str, MtlMap]]:
    """Per material (``newmtl``'s name, as trimesh keys it) of the MTL file ``mtl`` whose
    ``text`` is given, its read maps by lower-case keyword (``MTL_MAP_KEYWORDS``), each
    file confined to the MTL's folder; a statement before any ``newmtl`` belongs to none."""
    materials: dict[str, dict[str, MtlMap]] = {}
    current: dict[str, MtlMap] | None = None
    for line in text.splitlines():
        words = line.split()
        if len(words) < 2:
            continue
        keyword = words[0].lower()
        if keyword == "newmtl":
            current = materials.setdefault(" ".join(words[1:]), {})
        elif keyword in MTL_MAP_KEYWORDS and current is not None:
            rest = line.strip()[len(words[0]) :]
            options, name = parse_map_statement(rest)
            if name:
                try:
                    file, refused = files.confine(name, mtl, policy), None
                except RefusedError as exc:
                    file, refused = None, str(exc)
                current[keyword] = MtlMap(words[0], name, file, options, refused)
    return materials


def obj_libraries(data: bytes) -> list[str]:
    """The names of an OBJ's ``mtllib`` statements (each the rest of its line, so that a
    name with spaces stays whole)."""
    return [
        line[6:].strip().decode("utf-8", errors="replace")
        for line in data.splitlines()
        if line.startswith(b"mtllib") and line[6:7].isspace()
    ]


# The element statements an OBJ's face indices count, each kind's name, one and many.
_OBJ_KIND_NAMES = {
    b"v": ("vertex", "vertices"),
    b"vt": ("texture coordinate", "texture coordinates"),
    b"vn": ("normal", "normals"),
}


def obj_face_problem(path: Path, data: bytes) -> str | None:
    """The first face of an OBJ whose index names no element (``f 1 2 6`` with 4 ``v``,
    an index 0, a ``vt`` or ``vn`` past the file's) or that holds a word no index reads,
    as one sentence naming the file, the line and the index; None when every face is
    sound. A positive index counts from the file's first element of its kind, a negative
    one back from the last one defined before the face (OBJ, Wavefront 1992).

    trimesh refuses only a vertex index past the end (with a raw ``IndexError`` that says
    neither line nor file) and reads an index 0 as the last vertex and a ``vt`` or ``vn``
    past the end as nothing, so every OBJ is checked before trimesh reads it: read line
    by line in Python, this runs only where ``_obj_faces_plain`` cannot vouch for the
    file (``obj_index_problem``)."""
    if b"\r" in data:
        data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    totals = dict.fromkeys(_OBJ_KIND_NAMES, 0)
    for line in io.BytesIO(data):  # a line at a time: no list of every line in memory
        words = _obj_words(line, 1)
        if words and words[0] in totals:
            totals[words[0]] += 1
    seen = dict.fromkeys(_OBJ_KIND_NAMES, 0)
    for number, line in enumerate(io.BytesIO(data), 1):
        words = _obj_words(line.split(b"#", 1)[0])
        if not words:
            continue
        if words[0] in seen:
            seen[words[0]] += 1
            continue
        if words[0] != b"f":
            continue
        for word in words[1:]:
            token = word.decode("utf-8", errors="replace")
            parts = word.split(b"/")
            if len(parts) > 3 or not parts[0]:
                return (
                    f"{path}: line {number}: face word '{token}' is not v, v/vt, v//vn or v/vt/vn"
                )
            for kind, part in zip(_OBJ_KIND_NAMES, parts, strict=False):
                if not part and kind != b"v":
                    continue
                try:
                    index = int(part)
                except ValueError:
                    return f"{path}: line {number}: face word '{token}' is not a whole number"
                limit = totals[kind] if index > 0 else seen[kind]
                if index == 0 or abs(index) > limit:
                    one, many = _OBJ_KIND_NAMES[kind]
                    if index < 0:
                        have = f"{seen[kind]} {one if seen[kind] == 1 else many} before it"
                    else:
                        total = totals[kind]
                        have = f"{total} {one if total == 1 else many} in the file"
                    return (
                        f"{path}: line {number}: face index {index} ('{token}') names no "
                        f"{one} ({have}; OBJ indices start at 1)"
                    )
    return None


def _obj_words(line: bytes, most: int = -1) -> list[bytes]:
    """``line``'s words as trimesh splits an OBJ line (``str.split``: every Unicode blank,
    ``\\x1c`` and a no-break space included), each back in UTF-8."""
    return [w.encode() for w in line.decode("utf-8", errors="replace").split(None, most)]


_WHITE = np.array([ord(" "), ord("\t"), ord("\n")], np.uint8)
_POWERS = 10 ** np.arange(16, dtype=np.int64)
_SCREEN_CHUNK = 1 << 18  # bytes screened at once (cut after a newline), and the longest line


def _obj_faces_plain(data: bytes) -> bool:
    """True where every face of the OBJ ``data`` is plainly sound: unindented statements,
    face words of positive decimal indices alone (``v``, ``v/vt``, ``v//vn``, ``v/vt/vn``;
    no sign, comment or other byte on a face line), none 0 and none past its kind's count
    in the file. Read with numpy over the bytes, a chunk of whole lines at a time, in a
    fraction of the time and of the peak memory trimesh's own parse of the file takes (the
    budget charges that parse); it may say False for a sound file (a negative index, an
    indented line): ``obj_face_problem`` then decides."""
    if b"\x0b" in data or b"\x0c" in data:
        return False  # whitespace that trimesh and obj_face_problem split on, this does not
    if b"\r" in data:
        data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    totals = np.zeros(3, np.int64)  # the file's v, vt and vn
    most = np.zeros(3, np.int64)  # the largest index of each kind a face names
    view = memoryview(data)
    start = 0
    while start < len(data):
        end = data.find(b"\n", start + _SCREEN_CHUNK)
        end = len(data) if end < 0 else end + 1
        found = _screen_lines(np.frombuffer(view[start:end], np.uint8))
        if found is None:
            return False
        totals += found[0]
        np.maximum(most, found[1], out=most)
        start = end
    return bool((most <= totals).all())


def _screen_lines(a: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``_obj_faces_plain`` on the whole lines ``a``: their v, vt and vn counts and the
    largest index of each kind their faces name, or None where a line is not plain."""
    n = len(a)
    starts = np.concatenate(([0], np.flatnonzero(a == ord("\n")) + 1))
    starts = starts[starts < n]

    def column(k: int) -> np.ndarray:  # each line's byte k, a newline past the end
        at = starts + k
        return np.where(at < n, a[np.minimum(at, n - 1)], ord("\n")).astype(np.uint8)

    c0, c1, c2 = column(0), column(1), column(2)
    if np.isin(c0, _WHITE[:2]).any():
        return None
    blank1, end2 = np.isin(c1, _WHITE[:2]), np.isin(c2, _WHITE)
    is_v = c0 == ord("v")
    counts = np.array(
        [
            np.count_nonzero(is_v & (blank1 | (c1 == ord("\n")))),
            np.count_nonzero(is_v & (c1 == ord("t")) & end2),
            np.count_nonzero(is_v & (c1 == ord("n")) & end2),
        ]
    )
    face = (c0 == ord("f")) & blank1
    if ((c0 == ord("f")) & ~blank1).any():
        return None  # "f" then another byte: trimesh may read a face the words here miss
    if not face.any():
        return counts, np.zeros(3, np.int64)
    # The face lines' bytes after their "f", each line's newline kept (it parts its last
    # word from the next line's first).
    inside = np.repeat(face, np.diff(np.append(starts, n)))
    inside[starts[face]] = False
    largest = _plain_words(a[inside])
    return None if largest is None else (counts, largest)


def _plain_words(text: np.ndarray) -> np.ndarray | None:
    """The largest v, vt and vn index the face words ``text`` name (bytes of whole face
    lines after their "f"), or None unless every word is ``v``, ``v/vt``, ``v//vn`` or
    ``v/vt/vn`` of positive decimal indices."""
    b = np.concatenate((_WHITE[:1], text, _WHITE[:1]))  # a blank before and after
    digit = (b >= ord("0")) & (b <= ord("9"))
    slash = b == ord("/")
    blank = np.isin(b, _WHITE)
    if not (digit | slash | blank).all():
        return None  # a sign, a comment or a word no index reads
    word_at = np.flatnonzero(~blank[1:] & blank[:-1]) + 1
    if slash[word_at].any():
        return None  # a word without its vertex index
    slashes = np.cumsum(slash, dtype=np.int32)
    word_end = np.flatnonzero(~blank[:-1] & blank[1:])
    if (slashes[word_end] - slashes[word_at] > 2).any():
        return None  # more than v/vt/vn
    most = np.zeros(3, np.int64)
    run_at = np.flatnonzero(digit[1:] & ~digit[:-1]) + 1  # each number's first digit
    if not len(run_at):
        return most
    lengths = np.flatnonzero(digit[:-1] & ~digit[1:]) + 1 - run_at
    if lengths.max() > 15:
        return None  # past any count (and int64's digits)
    word = np.searchsorted(word_at, run_at, side="right") - 1
    slot = slashes[run_at] - slashes[word_at[word]]  # 0 v, 1 vt, 2 vn
    last = run_at + lengths - 1
    values = np.zeros(len(run_at), np.int64)
    for place in range(int(lengths.max())):  # the digits by place value, from the last
        values += np.where(place < lengths, b[last - place] - ord("0"), 0) * _POWERS[place]
    if (values == 0).any():
        return None
    np.maximum.at(most, slot, values)
    return most


def obj_index_problem(path: Path, data: bytes) -> str | None:
    """``obj_face_problem`` for an OBJ whose faces ``_obj_faces_plain`` cannot vouch for;
    None at once for one it can (nearly every file, and the fast way). A line longer than
    ``_SCREEN_CHUNK`` is refused first: either reading would hold it whole, at tens of
    bytes a byte, where no mesh has a statement that long."""
    if b"\r" in data:
        data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    long = _overlong_line(data)
    if long is not None:
        number, length = long
        return (
            f"{path}: line {number}: a line of {length} bytes "
            f"(OBJ lines are read up to {_SCREEN_CHUNK} bytes)"
        )
    return None if _obj_faces_plain(data) else obj_face_problem(path, data)


def _overlong_line(data: bytes) -> tuple[int, int] | None:
    """The first line of ``data`` (newlines alone) longer than ``_SCREEN_CHUNK`` bytes, as
    its number and length, or None. Each such line holds a point ``_SCREEN_CHUNK`` past
    the start of a chunk as ``_obj_faces_plain`` cuts them, so only those lines are read."""
    start = 0
    while start + _SCREEN_CHUNK < len(data):
        cut = start + _SCREEN_CHUNK
        first = data.rfind(b"\n", start, cut) + 1 or start
        end = data.find(b"\n", cut)
        end = len(data) if end < 0 else end
        if end - first > _SCREEN_CHUNK:
            return data.count(b"\n", 0, first) + 1, end - first
        start = end + 1
    return None


@dataclass(frozen=True)
class MtlFile:
    """One MTL file an OBJ names: the name as written, the confined path, its bytes (read
    once: for its maps here and for trimesh's resolver) and its materials' maps."""

    name: str
    path: Path
    data: bytes
    materials: dict[str, dict[str, MtlMap]]


def obj_mtl_files(path: Path, libraries: list[str], policy: InputPolicy) -> list[MtlFile]:
    """The OBJ ``path``'s MTL files (``obj_libraries``), each confined, read and parsed
    once; ``RefusedError`` saying which, for one outside the folder or unreadable."""
    out = []
    for name in libraries:
        try:
            mtl = files.confine(name, path, policy)
        except RefusedError as exc:
            raise RefusedError(f"{path}: mtllib: {exc}") from None
        try:
            data = files.read_bytes(mtl, policy.limits.max_text_bytes)
        except RefusedError as exc:
            raise RefusedError(f"{path}: mtllib {name}: {exc}") from None
        text = data.decode("utf-8", errors="replace")
        out.append(MtlFile(name, mtl, data, mtl_materials(mtl, text, policy)))
    return out


def obj_problem(path: Path, mtls: list[MtlFile], policy: InputPolicy) -> str | None:
    """The first problem with the images of the maps an OBJ's MTL files name that the
    project reads (``MTL_MAP_KEYWORDS``): outside the folder, missing, not an image."""
    for mtl in mtls:
        for maps in mtl.materials.values():
            for m in maps.values():
                if m.file is None:
                    return f"{path}: {mtl.path.name}: {m.keyword}: {m.refused}"
                why = _unreadable(m.file, True, policy)
                if why is not None:
                    return f"{path}: {mtl.path.name}: {m.keyword} {m.name}: {why}"
    return None


def obj_materials(mtls: list[MtlFile]) -> dict[str, dict[str, MtlMap]]:
    """The maps of every material of an OBJ's MTL files, by material name; a name defined
    twice keeps its first definition."""
    materials: dict[str, dict[str, MtlMap]] = {}
    for mtl in mtls:
        for material, maps in mtl.materials.items():
            materials.setdefault(material, maps)
    return materials
