"""Resource bombs: small inputs that would cost gigabytes or never end, each refused up
front at the default limits (docs/stability.md, "Limits"), in one line, without the
memory or the time it asks for.

glTF accessors of 2^24 or 2^28 zeros, thousands of nodes drawing one mesh, node chains
100,000 deep and 100,000 siblings, a buffer that claims 24 GiB (a sparse file), images
and environments whose headers declare more texels than any machine holds, an 8192^2
16-bit normal map, deep nesting in every parsed format, FIFOs and /dev/zero where a file
is expected, shadow atlases past the GL's limits, render sizes past the targets' budget,
scene tables of 100,000 entries, STL and PLY headers that lie about their counts. Held to
the contract of tests/attacks.py, and each must be refused (``expect="refused"``) except
where the input is bounded anyway and renders within the memory cap.
"""

from __future__ import annotations

import json
import os
import struct
import zlib
from pathlib import Path

import pytest

from tests.attacks import Case, escapes, run_cases, scene_head

pytestmark = pytest.mark.gl  # the bombs' scenes go as far as the renderer

HEAD = scene_head() + "[materials.m]\nroughness = 0.5\n"
MESH = '[[objects]]\nshape = "mesh"\nfile = "{f}"\n'
SPHERE = '[[objects]]\nshape = "sphere"\nmaterial = "m"\n'
SPHERE_N = '[[objects]]\nshape = "sphere"\nmaterial = "n"\n'


def _gltf(nodes: list[dict] | None = None, roots: list[int] | None = None, **accessor) -> dict:
    """A one-triangle glTF whose POSITION accessor takes ``accessor``'s fields."""
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,"
                     + "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       **accessor}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "nodes": nodes if nodes is not None else [{"mesh": 0}],
        "scenes": [{"nodes": roots if roots is not None else [0]}],
    }  # fmt: skip
    return doc


def _png(width: int, height: int, depth: int, colour: int, rows: int | None = None) -> bytes:
    """A PNG of ``width`` x ``height`` (of ``rows`` rows of zeros, compressed, where
    given: a real image that inflates to its full size)."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
        )

    ihdr = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0)
    body = chunk(b"IHDR", ihdr)
    if rows:
        channels = {0: 1, 2: 3, 4: 2, 6: 4}[colour]
        row = b"\x00" * (1 + width * channels * depth // 8)
        z = zlib.compressobj(9)
        data = b"".join(z.compress(row) for _ in range(rows)) + z.flush()
        body += chunk(b"IDAT", data)
    return b"\x89PNG\r\n\x1a\n" + body + chunk(b"IEND", b"")


def _bombs(folder: Path) -> list[tuple[str, str, str]]:
    """(id, scene text or "" for a raw argv case, expected outcome)."""
    out: list[tuple[str, str, str]] = []

    def gltf(name: str, doc: dict | str) -> str:
        (folder / name).write_text(doc if isinstance(doc, str) else json.dumps(doc))
        return MESH.format(f=name)

    out.append(("accessor-2^24-zeros", gltf("a24.gltf", _gltf(count=2**24, bufferView=None)),
                "refused"))  # fmt: skip
    zeros = _gltf(count=2**28)
    del zeros["accessors"][0]["bufferView"]
    out.append(("accessor-2^28-zeros", gltf("a28.gltf", zeros), "refused"))
    big = _gltf(count=2**24)
    big["bufferViews"][0]["byteLength"] = 2**24 * 12
    big["buffers"][0] = {"byteLength": 2**24 * 12, "uri": "big.bin"}
    (folder / "big.bin").write_bytes(b"\x00" * 64)
    out.append(("buffer-shorter-than-claimed", gltf("short.gltf", big), "refused"))
    sparse = {"byteLength": 24 << 30, "uri": "sparse.bin"}
    with open(folder / "sparse.bin", "wb") as f:
        f.truncate(24 << 30)
    doc = _gltf()
    doc["buffers"] = [sparse]
    doc["bufferViews"][0]["byteLength"] = 36
    out.append(("buffer-24GiB-sparse", gltf("sparse.gltf", doc), "refused"))
    nodes = [{"mesh": 0} for _ in range(3000)]
    out.append(("3000-instances", gltf("inst.gltf", _gltf(nodes, list(range(3000)))), "either"))
    nodes = [{"mesh": 0} for _ in range(100_000)]
    out.append(("100000-siblings", gltf("sib.gltf", _gltf(nodes, list(range(100_000)))),
                "refused"))  # fmt: skip
    chain = [{"children": [i + 1]} for i in range(99_999)] + [{"mesh": 0}]
    out.append(("100000-deep-chain", gltf("chain.gltf", _gltf(chain, [0])), "refused"))
    scaled = [{"children": [i + 1], "scale": [1e6, 1e6, 1e6]} for i in range(20)] + [{"mesh": 0}]
    out.append(("scale-overflow-chain", gltf("scaled.gltf", _gltf(scaled, [0])), "refused"))
    deep = '{"asset": {"version": "2.0"}, "extras": ' + "[" * 100_000 + "]" * 100_000 + "}"
    out.append(("gltf-json-100000-deep", gltf("deep.gltf", deep), "refused"))
    wide = _gltf()
    wide["extras"] = list(range(1_000_000))
    out.append(("gltf-array-1e6", gltf("wide.gltf", wide), "refused"))
    (folder / "huge.gltf").write_bytes(b'{"asset": {"version": "2.0"}, "extras": "'
                                       + b" " * (70 << 20) + b'"}')  # fmt: skip
    out.append(("gltf-json-70MiB", MESH.format(f="huge.gltf"), "refused"))
    draco = _gltf()
    draco["meshes"][0]["primitives"][0]["extensions"] = {
        "KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0}}
    }
    draco["accessors"][0].update(count=2**26)
    draco["extensionsRequired"] = draco["extensionsUsed"] = ["KHR_draco_mesh_compression"]
    out.append(("draco-declares-2^26", gltf("draco.gltf", draco), "refused"))
    # images and environments
    (folder / "rgba16.png").write_bytes(_png(8192, 8192, 16, 6, rows=8192))
    out.append(("normal-map-8192-rgba16", '[materials.n]\nnormal_map = "rgba16.png"\n'
                + SPHERE_N, "refused"))  # fmt: skip
    (folder / "lie.png").write_bytes(_png(200_000, 200_000, 8, 2))
    out.append(("png-declares-4e10", '[materials.n]\nbase_color_map = "lie.png"\n' + SPHERE_N,
                "refused"))  # fmt: skip
    for name, head in (
        ("hdr-1e6x2e6", b"-Y 1000000 +X 2000000\n"),
        ("hdr-16384x8192", b"-Y 8192 +X 16384\n"),
    ):
        (folder / f"{name}.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + head)
        out.append((name, f'[environment]\nsource = "image"\nfile = "{name}.hdr"\n' + SPHERE,
                    "refused"))  # fmt: skip
    w, h = 4096, 2048  # runs of one component each: 33.5 M Python steps to decode
    row = bytes([2, 2, w >> 8, w & 255]) + (bytes([1, 100]) * w) * 3 + bytes([1, 128]) * w
    head = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode()
    (folder / "runs.hdr").write_bytes(head + row * h)
    out.append(("hdr-one-component-runs", '[environment]\nsource = "image"\nfile = "runs.hdr"\n'
                + SPHERE, "refused"))  # fmt: skip
    # special files
    os.mkfifo(folder / "fifo.png")
    out.append(("fifo-texture", '[materials.n]\nbase_color_map = "fifo.png"\n'
                + SPHERE_N, "refused"))  # fmt: skip
    os.mkfifo(folder / "fifo.obj")
    out.append(("fifo-mesh", MESH.format(f="fifo.obj"), "refused"))
    os.mkfifo(folder / "fifo.hdr")
    out.append(("fifo-environment", '[environment]\nsource = "image"\nfile = "fifo.hdr"\n'
                + SPHERE, "refused"))  # fmt: skip
    os.mkfifo(folder / "fifo.bin")
    fifo = _gltf()
    fifo["buffers"][0]["uri"] = "fifo.bin"
    out.append(("fifo-buffer", gltf("fifo-buffer.gltf", fifo), "refused"))
    os.symlink("/dev/zero", folder / "zero.png")
    out.append(("dev-zero-texture", '[materials.n]\nbase_color_map = "zero.png"\n'
                + SPHERE_N, "refused"))  # fmt: skip
    os.symlink("/dev/zero", folder / "zero.obj")
    out.append(("dev-zero-mesh", MESH.format(f="zero.obj"), "refused"))
    # the GPU side
    out.append(("shadow-16384-4-cascades", SPHERE + '[[lights]]\ntype = "directional"\n'
                'direction = [0.0, -1.0, 0.0]\nshadow = true\nshadow_resolution = 16384\n'
                'shadow_cascades = 4\n', "refused"))  # fmt: skip
    out.append(("shadow-point-16384", SPHERE + '[[lights]]\ntype = "point"\n'
                'position = [0.0, 2.0, 0.0]\nshadow = true\nshadow_resolution = 16384\n',
                "refused"))  # fmt: skip
    # scene tables
    one = '[[objects]]\nshape = "sphere"\nmaterial = "m"\nposition = [{}.0, 0.0, 0.0]\n'
    many = "".join(one.format(i % 100) for i in range(20_000))
    out.append(("20000-objects", many, "refused"))
    lights = "".join(
        '[[lights]]\ntype = "point"\nposition = [0.0, 1.0, 0.0]\n' for _ in range(5000)
    )
    out.append(("5000-lights", SPHERE + lights, "refused"))
    materials = "".join(f"[materials.x{i}]\nroughness = 0.5\n" for i in range(5000))
    out.append(("5000-materials", materials + SPHERE, "refused"))
    out.append(("toml-100000-deep", "x = " + "[" * 100_000 + "]" * 100_000 + "\n", "refused"))
    out.append(("toml-20MiB", "# " + "x" * (20 << 20) + "\n" + SPHERE, "refused"))
    # mesh files
    (folder / "stl-lie.stl").write_bytes(b"\0" * 80 + struct.pack("<I", 2**32 - 1) + b"\0" * 50)
    out.append(("stl-count-2^32", MESH.format(f="stl-lie.stl"), "refused"))
    ply = (
        b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\n"
        b"property float x\nproperty float y\nproperty float z\nend_header\n" + b"\0" * 120
    )
    (folder / "ply-lie.ply").write_bytes(ply)  # fmt: skip
    out.append(("ply-count-1e9", MESH.format(f="ply-lie.ply"), "refused"))
    (folder / "mtl-huge.mtl").write_bytes(b"newmtl m\n" + b"# " + b"x" * (20 << 20) + b"\n")
    (folder / "mtl-huge.obj").write_text(
        "mtllib mtl-huge.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
    )
    out.append(("mtl-20MiB", MESH.format(f="mtl-huge.obj"), "refused"))
    return out


def _raw_cases(folder: Path) -> list[Case]:
    """Bombs given on the command line rather than in a scene."""
    scene = folder / "plain.toml"
    scene.write_text(HEAD + SPHERE, encoding="utf-8")
    os.mkfifo(folder / "fifo.toml")
    deep_job = folder / "deep.json"
    deep_job.write_text('{"scenes": ' + "[" * 100_000 + "]" * 100_000 + "}")
    deep_toml_job = folder / "deep-job.toml"
    deep_toml_job.write_text("scenes = " + "[" * 100_000 + "]" * 100_000 + "\n")
    (folder / "tex.png").write_bytes(_png(4, 4, 8, 2, rows=4))
    import numpy as np

    from tests.test_attack_images import _exr

    (folder / "env.exr").write_bytes(_exr(np.ones((8, 16, 3), np.float32)))
    textured = folder / "textured.toml"
    textured.write_text(HEAD + '[materials.n]\nbase_color_map = "tex.png"\n' + SPHERE_N
                        + '[environment]\nsource = "image"\nfile = "env.exr"\n')  # fmt: skip
    out = folder / "o.png"
    cases = [
        ("dev-zero-scene", ["render", "/dev/zero", "-o", str(out)]),
        ("fifo-scene", ["render", str(folder / "fifo.toml"), "-o", str(out)]),
        ("size-16384-supersample", ["render", str(scene), "-o", str(out), "--size", "16384x16384"]),
        # 3.75 GiB of targets: within the default 4 GiB, past a 1 GiB budget
        ("size-8192-f32-1G",
         ["render", str(scene), "-o", str(out), "--size", "8192x8192", "--max-memory", "1G"]),
        ("batch-json-100000-deep", ["batch", str(deep_job), "-o", str(folder / "b1")]),
        ("batch-toml-100000-deep", ["batch", str(deep_toml_job), "-o", str(folder / "b2")]),
        ("output-onto-its-texture", ["render", str(textured), "-o", str(folder / "tex.png")]),
        ("hdr-onto-its-texture",
         ["render", str(textured), "-o", str(out), "--hdr", str(folder / "env.exr")]),
    ]  # fmt: skip
    if os.geteuid() == 0:  # a device node named like an output (mknod needs root)
        os.mknod(folder / "device.png", 0o20666, os.makedev(1, 3))
        cases.append(
            ("output-onto-a-device", ["render", str(scene), "-o", str(folder / "device.png")])
        )
    made = []
    for case_id, argv in cases:  # each its own output, so that one case's cannot count
        own = folder / f"raw-{case_id}.png"
        argv = [str(own) if a == str(out) else a for a in argv]
        made.append(Case(case_id, [*argv, "--backend", "egl", "-q"], str(folder), [str(own)],
                         None, "refused"))  # fmt: skip
    return made


def cases(folder: Path) -> list[Case]:
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for case_id, body, expect in _bombs(folder):
        scene = folder / f"{case_id}.toml"
        scene.write_text(HEAD + body if not body.startswith("x = ") else body, encoding="utf-8")
        png = folder / f"{case_id}.png"
        argv = ["render", str(scene), "-o", str(png), "--backend", "egl", "-q"]
        out.append(Case(case_id, argv, str(folder), [str(png)], None,
                        None if expect == "either" else expect))  # fmt: skip
    return out + _raw_cases(folder)


def test_resource_bombs_are_refused_up_front(tmp_path: Path) -> None:
    found_cases = cases(tmp_path / "asset")
    assert len(found_cases) >= 42, len(found_cases)
    outcomes = run_cases(found_cases, tmp_path)
    found = escapes(found_cases, outcomes)
    assert not found, f"{len(found)} of {len(found_cases)} escaped:\n" + "\n".join(found)
    # What the outputs named is still there: the texture, the device node.
    asset = tmp_path / "asset"
    assert (asset / "tex.png").read_bytes().startswith(b"\x89PNG")
    assert (asset / "env.exr").read_bytes().startswith(b"\x76\x2f\x31\x01")
    if (asset / "device.png").exists() or os.geteuid() == 0:
        assert (asset / "device.png").is_char_device()


def test_a_full_disk_while_writing_the_hdr_is_one_line(tmp_path: Path) -> None:
    """OpenEXR raised its own RuntimeError (a traceback) when the disk filled up under
    ``--hdr x.exr``; a file-size limit (RLIMIT_FSIZE, what a full disk looks like to a
    writer: EFBIG on the next write) makes it exit 2 with one line, and leaves no file."""
    import resource
    import signal
    import subprocess
    import sys

    scene = tmp_path / "scene.toml"
    scene.write_text(HEAD + SPHERE, encoding="utf-8")
    out, hdr = tmp_path / "out.png", tmp_path / "out.exr"

    def small_disk() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (2048, 2048))

    repo = Path(__file__).resolve().parent.parent
    proc = subprocess.run(
        [sys.executable, "-m", "app", "render", str(scene), "-o", str(out), "--hdr", str(hdr),
         "--size", "320x180", "--backend", "egl"],
        cwd=repo, env={**os.environ, "PYTHONPATH": str(repo), "MESA_SHADER_CACHE_DISABLE": "true"},
        capture_output=True, text=True, preexec_fn=small_disk, timeout=120,
    )  # fmt: skip
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and "--hdr: cannot write" in lines[0], proc.stderr
    assert not hdr.exists() and not out.exists()
    assert not list(tmp_path.glob(".out.*")), list(tmp_path.glob(".out.*"))
