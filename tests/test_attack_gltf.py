"""Mutated glTF files, as an attacker writes them: refused in one line or rendered finite.

Five valid seeds (a feature-rich GLB with textures, samplers, a transform, TEXCOORD_1,
COLOR_0, TANGENT, a sparse accessor and a child node; a .gltf whose buffer and images are
files beside it; the bundled material sampler; the bundled stage with its camera and
KHR_lights_punctual lights; a Draco GLB) are mutated by a seeded generator: a JSON value
replaced by a hostile one (wrong types, 0.5 for an index, "1" for a number, 1e400, huge
counts and lengths, traversal URIs), keys and entries deleted or duplicated, arrays grown
(thousands of nodes instancing one mesh), node cycles and deep chains, accessors stripped
of their bufferView, deep JSON nesting, and GLB headers and chunks damaged byte by byte.
Every mutant is rendered by ``pbs render`` and held to the contract of tests/attacks.py
(exit 2 with one line or exit 0 with a finite image, no traceback, no hang, no memory
spike, nothing outside the asset's folder opened).

``CASES_SAMPLED`` mutants run in every test run; the whole suite (``CASES``) runs with
``-m whole`` (docs/stability.md, "Attack suites").
"""

from __future__ import annotations

import copy
import json
import random
import struct
from pathlib import Path

import pytest

from tests.attacks import Case, escapes, run_cases
from tests.gltf_builder import GltfBuilder, png_rgb
from tests.test_gltf_fuzz import _valid

pytestmark = pytest.mark.gl  # the files that load are rendered

REPO = Path(__file__).resolve().parent.parent
CASES = 1200  # the whole suite (-m whole)
CASES_SAMPLED = 240  # every test run
SIZE = "24x16"
MAX_MEMORY = "1G"  # the budget every mutant runs under; tests/attacks.py MAX_PEAK holds it
SCENE = """\
[camera]
position = [0.0, 0.5, 3.0]
target = [0.0, 0.0, 0.0]

[[lights]]
type = "directional"
direction = [0.0, -0.5, -1.0]

[[objects]]
shape = "mesh"
file = "{file}"
{extra}"""

HOSTILE = [
    -1, 0, 1, 3, 7, 4096, 2**24, 2**31, 2**31 - 1, 2**53 + 1, 2**64, -(2**63),
    0.5, 1.5, -0.0, 1e-320, 1e300, -1e300, float("inf"), float("nan"),
    "1", "", "x", "../../secret/secret.bin", "%2e%2e/%2e%2e/secret/secret.png",
    "/etc/hostname", "file:///etc/hostname", "data:,", "data:application/octet-stream;base64,!!",
    None, True, False, [], {}, [1, 2], [0.5, 0.5, 0.5], {"index": 0}, [[0]], "VEC3", 5126,
]  # fmt: skip


def _glb_parts(data: bytes) -> tuple[dict, bytes]:
    (n,) = struct.unpack("<I", data[12:16])
    doc = json.loads(data[20 : 20 + n])
    return doc, data[28 + n :]


def _glb(doc: object, blob: bytes, version: int = 2) -> bytes:
    return _glb_text(json.dumps(doc, separators=(",", ":")).encode(), blob, version)


def _glb_text(text: bytes, blob: bytes, version: int = 2) -> bytes:
    """A GLB of JSON ``text`` and BIN chunk ``blob`` (none where empty)."""
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text
    if blob:
        body += struct.pack("<II", len(blob), 0x004E4942) + blob
    return b"glTF" + struct.pack("<II", version, 12 + len(body)) + body


def _leaves(node: object, path: tuple = ()) -> list[tuple]:
    out = [path] if path else []
    stack = [(node, path)]
    while stack:
        value, at = stack.pop()
        if isinstance(value, dict):
            for k, v in value.items():
                out.append((*at, k))
                stack.append((v, (*at, k)))
        elif isinstance(value, list):
            for i, v in enumerate(value):
                out.append((*at, i))
                stack.append((v, (*at, i)))
    return out


def _at(doc: object, path: tuple) -> tuple[object, object]:
    target = doc
    for key in path[:-1]:
        target = target[key]  # type: ignore[index]
    return target, path[-1]


class Seed:
    """A valid glTF: its JSON, its BIN chunk (GLB) and the files it needs beside it."""

    def __init__(self, name: str, doc: dict, blob: bytes, glb: bool, files: dict[str, bytes],
                 extra: str = "") -> None:  # fmt: skip
        self.name, self.doc, self.blob, self.glb = name, doc, blob, glb
        self.files, self.extra = files, extra

    def write(self, folder: Path, stem: str, doc: object, blob: bytes | None = None) -> str:
        for name, data in self.files.items():
            if not (folder / name).exists():
                (folder / name).write_bytes(data)
        name = f"{stem}.{'glb' if self.glb else 'gltf'}"
        if self.glb:
            (folder / name).write_bytes(_glb(doc, self.blob if blob is None else blob))
        else:
            (folder / name).write_text(json.dumps(doc), encoding="utf-8")
        return name


def _seeds(folder: Path) -> list[Seed]:
    seeds = []
    rich = _valid(folder).read_bytes()
    doc, blob = _glb_parts(rich)
    seeds.append(Seed("rich", doc, blob, True, {}))
    b = GltfBuilder()
    b.image(png_rgb((200, 50, 50)), how="file", folder=folder)
    import pygltflib

    b.doc.textures.append(pygltflib.Texture(source=0))
    material = b.material(pygltflib.Material(
        pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
            baseColorTexture=pygltflib.TextureInfo(index=0)),
        normalTexture=pygltflib.NormalMaterialTexture(index=0),
    ))  # fmt: skip
    b.quad(material)
    path = b.save(folder / "files.gltf")
    side = {p.name: p.read_bytes() for p in folder.iterdir() if p.suffix in (".bin", ".png")}
    seeds.append(Seed("files", json.loads(path.read_text()), b"", False, side))
    sampler = (REPO / "scenes" / "meshes" / "material_sampler.glb").read_bytes()
    doc, blob = _glb_parts(sampler)
    seeds.append(Seed("sampler", doc, blob, True, {}))
    stage = json.loads((REPO / "scenes" / "meshes" / "stage.gltf").read_text(encoding="utf-8"))
    seeds.append(Seed("stage", stage, b"", False, {}, "import_lights = true\n"))
    d = GltfBuilder()
    d.draco_quad()
    draco = d.save(folder / "draco.glb").read_bytes()
    doc, blob = _glb_parts(draco)
    seeds.append(Seed("draco", doc, blob, True, {}))
    return seeds


def _mutate(seed: Seed, rng: random.Random) -> tuple[str, object, bytes | None, bytes | None]:
    """(description, JSON document, BIN chunk or None (the seed's), raw file bytes or
    None): one hostile change of the seed."""
    doc = copy.deepcopy(seed.doc)
    kind = rng.choices(
        ["value", "delete", "duplicate", "grow", "cycle", "chain", "strip-view", "nest",
         "counts", "uri", "extension", "glb"],
        weights=[30, 8, 5, 4, 3, 3, 4, 3, 8, 5, 7, 12 if seed.glb else 0],
    )[0]  # fmt: skip
    leaves = _leaves(doc)
    if kind == "value":
        path = rng.choice(leaves)
        target, key = _at(doc, path)
        value = rng.choice(HOSTILE)
        target[key] = value  # type: ignore[index]
        return f"{path} = {value!r}", doc, None, None
    if kind == "delete":
        path = rng.choice(leaves)
        target, key = _at(doc, path)
        del target[key]  # type: ignore[arg-type]
        return f"deleted {path}", doc, None, None
    if kind == "duplicate":
        lists = [p for p in leaves if isinstance(_at(doc, p)[0], list)]
        path = rng.choice(lists)
        target, key = _at(doc, path)
        target.insert(key, copy.deepcopy(target[key]))  # type: ignore[attr-defined,index]
        return f"duplicated {path}", doc, None, None
    if kind == "grow":  # many nodes showing the first mesh
        count = rng.choice([100, 3000, 70_000])
        first = len(doc.get("nodes", []))
        mesh = next((i for i, n in enumerate(doc.get("nodes", [])) if "mesh" in n), None)
        if mesh is None:
            return "no mesh node", doc, None, None
        node = doc["nodes"][mesh]
        doc.setdefault("nodes", []).extend({"mesh": node["mesh"]} for _ in range(count))
        scene = doc.setdefault("scenes", [{"nodes": []}])[doc.get("scene", 0) or 0]
        scene.setdefault("nodes", []).extend(range(first, first + count))
        return f"{count} nodes instancing a mesh", doc, None, None
    if kind == "cycle":
        nodes = doc.get("nodes", [])
        if not nodes:
            return "no nodes", doc, None, None
        i = rng.randrange(len(nodes))
        j = rng.randrange(len(nodes))
        nodes[i].setdefault("children", []).append(j)
        return f"node {i} -> {j}", doc, None, None
    if kind == "chain":
        depth = rng.choice([100, 1500, 100_000])
        first = len(doc.get("nodes", []))
        nodes = doc.setdefault("nodes", [])
        nodes.extend({"children": [first + k + 1], "scale": [1.5, 1.5, 1.5]}
                     for k in range(depth - 1))  # fmt: skip
        mesh_node = next((n for n in nodes if "mesh" in n), None)
        nodes.append({"mesh": mesh_node["mesh"]} if mesh_node else {})
        scene = doc.setdefault("scenes", [{"nodes": []}])[doc.get("scene", 0) or 0]
        scene.setdefault("nodes", []).append(first)
        return f"a chain of {depth} nodes", doc, None, None
    if kind == "strip-view":
        accessors = doc.get("accessors", [])
        if not accessors:
            return "no accessors", doc, None, None
        a = rng.choice(accessors)
        a.pop("bufferView", None)
        a["count"] = rng.choice([4, 2**24, 2**28])
        return f"an accessor of {a['count']} zeros", doc, None, None
    if kind == "nest":
        path = rng.choice(leaves)
        target, key = _at(doc, path)
        levels = rng.choice([70, 3000, 100_000])
        target[key] = "@DEEP@"  # type: ignore[index]
        # json.dumps recurses: the deep value is written as text
        text = json.dumps(doc).replace('"@DEEP@"', "[" * levels + "0" + "]" * levels)
        return f"{path} nested {levels} deep", text, None, None
    if kind == "counts":
        table = rng.choice(["accessors", "bufferViews", "buffers"])
        entries = doc.get(table, [])
        if not entries:
            return f"no {table}", doc, None, None
        e = rng.choice(entries)
        field = {"accessors": rng.choice(["count", "byteOffset"]),
                 "bufferViews": rng.choice(["byteLength", "byteOffset", "byteStride"]),
                 "buffers": "byteLength"}[table]  # fmt: skip
        e[field] = rng.choice([2**24, 2**31 - 1, 2**32, 3, 1, 255, 2**20 + 3])
        return f"{table}.{field} = {e[field]}", doc, None, None
    if kind == "uri":
        table = rng.choice(["buffers", "images"])
        entries = doc.get(table, [])
        if not entries:
            return f"no {table}", doc, None, None
        uri = rng.choice([*HOSTILE[22:29], "secret/../../secret/secret.bin", "./", "."])
        rng.choice(entries)["uri"] = uri
        return f"{table} uri {uri!r}", doc, None, None
    if kind == "extension":
        materials = doc.get("materials", [])
        if not materials:
            return "no materials", doc, None, None
        m = rng.choice(materials)
        name, value = rng.choice([
            ("KHR_materials_clearcoat", {"clearcoatFactor": rng.choice(HOSTILE)}),
            ("KHR_materials_sheen", {"sheenColorFactor": rng.choice(HOSTILE)}),
            ("KHR_materials_ior", {"ior": rng.choice(HOSTILE)}),
            ("KHR_materials_emissive_strength", {"emissiveStrength": rng.choice(HOSTILE)}),
            ("KHR_materials_iridescence", {"iridescenceThicknessMaximum": rng.choice(HOSTILE)}),
            ("KHR_materials_anisotropy", {"anisotropyRotation": rng.choice(HOSTILE)}),
            ("KHR_materials_specular", {"specularColorFactor": rng.choice(HOSTILE)}),
            ("KHR_materials_clearcoat", {"clearcoatNormalTexture": {"index": 0,
                                         "scale": rng.choice(HOSTILE)}}),
        ])  # fmt: skip
        m.setdefault("extensions", {})[name] = value
        pbr = m.setdefault("pbrMetallicRoughness", {})
        if rng.random() < 0.5 and doc.get("textures"):
            transform = {"scale": [rng.choice([1e300, 1e7, -1e6, 2.0]), 1.0],
                         "offset": [rng.choice([1e30, 0.5]), 0.0],
                         "rotation": rng.choice([1e30, 7.0, float("nan")])}  # fmt: skip
            pbr["baseColorTexture"] = {
                "index": 0,
                "extensions": {"KHR_texture_transform": transform},
            }
        return f"{name} = {value!r}", doc, None, None
    # glb: the container itself
    raw = bytearray(_glb(doc, seed.blob))
    how = rng.choice(["version", "length", "chunk-length", "chunk-type", "truncate", "flip",
                      "no-bin", "extra-chunk"])  # fmt: skip
    if how == "version":
        struct.pack_into("<I", raw, 4, rng.choice([0, 1, 3, 2**32 - 1]))
    elif how == "length":
        struct.pack_into("<I", raw, 8, rng.choice([0, 12, len(raw) + 4, 2**32 - 1]))
    elif how == "chunk-length":
        struct.pack_into("<I", raw, 12, rng.choice([0, 3, 2**31, 2**32 - 1]))
    elif how == "chunk-type":
        struct.pack_into("<I", raw, 16, rng.choice([0, 0x004E4942, 0x12345678]))
    elif how == "truncate":
        raw = raw[: rng.randrange(0, len(raw))]
    elif how == "flip":
        for _ in range(rng.randint(1, 8)):
            raw[rng.randrange(len(raw))] = rng.randrange(256)
    elif how == "no-bin":
        raw = bytearray(_glb(doc, b""))
    else:
        raw += struct.pack("<II", 8, 0x41414141) + b"AAAAAAAA"
        struct.pack_into("<I", raw, 8, len(raw))
    return f"GLB {how}", doc, None, bytes(raw)


def cases(folder: Path, count: int, seed: int = 27) -> tuple[list[Case], dict[str, str]]:
    """``count`` mutants in ``folder`` (asset/, with secret/ beside it), and what each is."""
    asset, secret = folder / "asset", folder / "secret"
    asset.mkdir(parents=True, exist_ok=True)
    secret.mkdir(exist_ok=True)
    (secret / "secret.bin").write_bytes(b"pbs-attack-secret-7f3a" * 64)
    png_rgb((1, 2, 3)).save(secret / "secret.png")
    seeds = _seeds(asset)
    rng = random.Random(seed)
    out, what = [], {}
    for i in range(count):
        s = seeds[i % len(seeds)]
        description, doc, blob, raw = _mutate(s, rng)
        stem = f"m{i:04d}-{s.name}"
        if raw is not None:
            name = f"{stem}.glb"
            (asset / name).write_bytes(raw)
        elif isinstance(doc, str):  # a deep document written as text
            name = f"{stem}.{'glb' if s.glb else 'gltf'}"
            text = doc.encode()
            if s.glb:
                (asset / name).write_bytes(_glb_text(text, s.blob))
            else:
                (asset / name).write_bytes(text)
        else:
            name = s.write(asset, stem, doc, blob)
        scene = asset / f"{stem}.toml"
        scene.write_text(SCENE.format(file=name, extra=s.extra), encoding="utf-8")
        png, hdr = asset / f"{stem}.png", asset / f"{stem}.npy"
        argv = ["render", str(scene), "-o", str(png), "--hdr", str(hdr), "--size", SIZE,
                "--backend", "egl", "-q", "--max-memory", MAX_MEMORY]  # fmt: skip
        out.append(Case(stem, argv, str(asset), [str(png), str(hdr)], str(secret), None, str(hdr)))
        what[stem] = description
    return out, what


def _run(tmp_path: Path, count: int) -> None:
    found_cases, what = cases(tmp_path, count)
    outcomes = run_cases(found_cases, tmp_path)
    found = escapes(found_cases, outcomes)
    rendered = sum(o.code == 0 for o in outcomes.values())
    refused = sum(o.code == 2 for o in outcomes.values())
    assert rendered > count // 20, f"only {rendered} mutants rendered: the seeds are broken"
    assert refused > count // 4, f"only {refused} mutants refused"
    assert not found, f"{len(found)} of {count} escaped:\n" + "\n".join(
        f"{line}  [{what[line.split(':')[0]]}]" for line in found[:40]
    )


def test_mutated_gltf_sample(tmp_path: Path) -> None:
    _run(tmp_path, CASES_SAMPLED)


@pytest.mark.whole
def test_mutated_gltf_whole(tmp_path: Path) -> None:
    _run(tmp_path, CASES)


def _named_cases() -> dict[str, tuple[callable, str]]:
    """The named cases: each change of the rich seed, and the key its refusal names."""

    def set_at(path: tuple, value: object):
        def change(doc: dict) -> None:
            target, key = _at(doc, path)
            target[key] = value  # type: ignore[index]

        return change

    def texture_transform(doc: dict) -> None:
        info = doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]
        info["extensions"]["KHR_texture_transform"]["scale"] = [1e300, 1.0]

    return {
        "texture-index-0.5": (
            set_at(("materials", 0, "pbrMetallicRoughness", "baseColorTexture", "index"), 0.5),
            "materials[0].pbrMetallicRoughness.baseColorTexture.index: must be an integer",
        ),
        "byte-offset-1.5": (
            set_at(("bufferViews", 0, "byteOffset"), 1.5),
            "bufferViews[0].byteOffset: must be an integer",
        ),
        "factor-string": (
            set_at(("materials", 0, "pbrMetallicRoughness", "baseColorFactor", 0), "1"),
            "baseColorFactor[0]: must be a number",
        ),
        "texture-transform-1e300": (
            texture_transform,
            "KHR_texture_transform.scale: 1e+300 is outside",
        ),
        "node-matrix-1e200": (
            set_at(("nodes", 0, "matrix"), [1e200] + [0.0] * 15),
            "nodes[0].matrix[0]: 1e+200 is outside",
        ),
        "glb-version-1": (None, "a GLB of version 1"),
    }


@pytest.mark.parametrize("case", list(_named_cases()))
def test_what_a_permissive_parser_repaired_is_refused(tmp_path: Path, capsys, case: str) -> None:
    """pygltflib, which read the JSON before, turned an index of 0.5 into 0, a byteOffset
    of 1.5 into 1 and "1" into 1.0, and the reader let a scale of 1e300 and a matrix of
    1e200 through with overflow warnings: each is exit 2 naming the key now."""
    from app.cli import main

    change, fragment = _named_cases()[case]
    doc, blob = _glb_parts(_valid(tmp_path).read_bytes())
    if change is not None:
        change(doc)
        data = _glb(doc, blob)
    else:
        data = _glb(doc, blob, version=1)
    (tmp_path / "case.glb").write_bytes(data)
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.format(file="case.glb", extra=""), encoding="utf-8")
    out = tmp_path / "out.png"
    code = main(["render", str(scene), "-o", str(out), "--size", SIZE, "--backend", "egl"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert fragment in err[0], err[0]
    assert not out.exists()
