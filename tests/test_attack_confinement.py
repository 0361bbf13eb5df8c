"""Nothing outside the referencing file's folder is read unless the user allows it.

Every place a file can name another file (a scene's mesh, texture, blend mask and
environment; a glTF buffer and image URI; an OBJ's MTL library and the MTL's maps; a batch
job's scenes) is pointed at a "secret" folder beside the asset's folder in every form a
path can take there: ``../``, an absolute path, percent-encoded (glTF URIs are
percent-decoded), through a symlinked file or folder, ``file:`` URIs. Each case must be
refused without Python opening anything under the secret folder (an audit hook watches
every open, tests/attacks.py) and with an error that quotes neither the secret's bytes nor
its size; a refused path's error is the same sentence whether the target exists or not.
``--allow-path`` widens the folder, and the same references then render. ``data:`` URIs
need no file and render.
"""

from __future__ import annotations

import base64
import io
import json
import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests.attacks import SECRET, Case, escapes, run_cases, scene_head
from tests.gltf_builder import GltfBuilder

pytestmark = pytest.mark.gl  # the scenes that load are rendered

SCENE_HEAD = scene_head() + "[materials.plain]\nroughness = 0.5\n"


def _png(colour: tuple[int, int, int], text: str = "") -> bytes:
    from PIL import PngImagePlugin

    info = PngImagePlugin.PngInfo()
    if text:
        info.add_text("secret", text)
    out = io.BytesIO()
    Image.new("RGB", (4, 4), colour).save(out, format="PNG", pnginfo=info)
    return out.getvalue()


def _hdr_bytes() -> bytes:
    """A 4 x 2 flat RGBE image."""
    head = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 4\n"
    return head + bytes([128, 128, 128, 129]) * 8


def _gltf(folder: Path, name: str, buffer_uri: str | None, image_uri: str | None) -> Path:
    """A quad .gltf whose buffer (and, with ``image_uri``, base colour image) live at the
    given URIs; ``None`` keeps them in ``name``.bin / a data: URI."""
    b = GltfBuilder()
    material = None
    if image_uri is not None:
        import pygltflib

        b.doc.images.append(pygltflib.Image(uri=image_uri))
        b.doc.textures.append(pygltflib.Texture(source=0))
        material = b.material(
            pygltflib.Material(
                pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
                    baseColorTexture=pygltflib.TextureInfo(index=0)
                )
            )
        )
    b.quad(material)
    path = b.save(folder / name)
    if buffer_uri is not None:
        doc = json.loads(path.read_text(encoding="utf-8"))
        doc["buffers"][0]["uri"] = buffer_uri
        path.write_text(json.dumps(doc), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def layout(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return make_layout(tmp_path_factory.mktemp("confine"))


def make_layout(root: Path) -> dict[str, Path]:
    """asset/ (the scene's folder) and secret/ beside it in ``root``, holding real files
    of every kind whose bytes start with SECRET where the format lets them; symlinks
    from asset/ into secret/."""
    asset, secret = root / "asset", root / "secret"
    asset.mkdir()
    secret.mkdir()
    (asset / "sub").mkdir()  # so that sub/../../secret resolves in the kernel too
    # A real glTF (secret.gltf) whose buffer secret.bin ends in SECRET.
    _gltf(secret, "secret.gltf", None, None)
    (secret / "secret.bin").write_bytes((secret / "secret.bin").read_bytes() + SECRET.encode())
    (secret / "secret.png").write_bytes(_png((250, 10, 10), SECRET))
    (secret / "secret.hdr").write_bytes(_hdr_bytes())
    (secret / "secret.mtl").write_text(f"# {SECRET}\nnewmtl m\nKd 1 0 0\n", encoding="utf-8")
    (secret / "secret.obj").write_text(
        f"# {SECRET}\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nf 1 2 3\n", encoding="utf-8"
    )
    (secret / "secret.toml").write_text(
        SCENE_HEAD + f'# {SECRET}\n[[objects]]\nshape = "sphere"\nmaterial = "plain"\n',
        encoding="utf-8",
    )
    (asset / "ok.png").write_bytes(_png((10, 200, 10)))
    os.symlink(secret, asset / "linkdir")
    os.symlink(secret / "secret.png", asset / "link.png")
    os.symlink(secret / "secret.bin", asset / "link.bin")
    os.symlink(secret / "secret.hdr", asset / "link.hdr")
    os.symlink(secret / "secret.obj", asset / "link.obj")
    return {"root": root, "asset": asset, "secret": secret}


def _forms(secret: Path, name: str) -> dict[str, str]:
    """The ways a path in a scene file can point at secret/``name`` from asset/."""
    return {
        "parent": f"../secret/{name}",
        "deep-parent": f"sub/../../secret/{name}",
        "dot-parent": f"./../secret/{name}",
        "absolute": str(secret / name),
        "linked-folder": f"linkdir/{name}",
    }


def _uri_forms(secret: Path, name: str) -> dict[str, str]:
    """The ways a glTF URI can point at secret/``name``: the scene forms and the
    percent-encoded and file: ones (URIs are percent-decoded)."""
    forms = _forms(secret, name)
    forms["percent"] = f"%2e%2e/secret/{name}"
    forms["percent-slash"] = f"..%2Fsecret%2F{name}"
    forms["file-uri"] = (secret / name).as_uri()
    return forms


def _scene(folder: Path, name: str, body: str) -> Path:
    path = folder / name
    path.write_text(SCENE_HEAD + body, encoding="utf-8")
    return path


def _render_case(
    case_id: str, layout: dict[str, Path], scene: Path, expect: str, allow: bool = False
) -> Case:
    out = layout["asset"] / f"{case_id}.png"
    argv = ["render", str(scene), "-o", str(out), "--backend", "egl", "-q"]
    if allow:
        argv += ["--allow-path", str(layout["secret"])]
    secret = None if allow else str(layout["secret"])
    return Case(case_id, argv, str(layout["asset"]), [str(out)], secret, expect)


def _cases(layout: dict[str, Path]) -> list[Case]:
    asset, secret = layout["asset"], layout["secret"]
    cases: list[Case] = []

    def add(kind: str, form: str, body: str, expect: str = "refused") -> None:
        case_id = f"{kind}-{form}"
        scene = _scene(asset, f"{case_id}.toml", body)
        cases.append(_render_case(case_id, layout, scene, expect))

    for form, ref in _forms(secret, "secret.obj").items():
        add("mesh-file", form, f'[[objects]]\nshape = "mesh"\nfile = "{ref}"\n')
    for form, ref in _forms(secret, "secret.gltf").items():
        add("gltf-file", form, f'[[objects]]\nshape = "mesh"\nfile = "{ref}"\n')
    for key in ("base_color_map", "normal_map", "roughness_map", "emissive_map"):
        extra = "emissive = [1.0, 1.0, 1.0]\n" if key == "emissive_map" else ""
        for form, ref in _forms(secret, "secret.png").items():
            add(key, form, f'[materials.m]\n{extra}{key} = "{ref}"\n'
                '[[objects]]\nshape = "sphere"\nmaterial = "m"\n')  # fmt: skip
    add("texture", "linked-file", '[materials.m]\nbase_color_map = "link.png"\n'
        '[[objects]]\nshape = "sphere"\nmaterial = "m"\n')  # fmt: skip
    for form, ref in _forms(secret, "secret.png").items():
        add("blend-mask", form, '[materials.top]\nmetallic = 1.0\n[materials.m]\n'
            f'blend = {{ material = "top", mask = "{ref}" }}\n'
            '[[objects]]\nshape = "sphere"\nmaterial = "m"\n')  # fmt: skip
    for form, ref in {**_forms(secret, "secret.hdr"), "linked-file": "link.hdr"}.items():
        add("environment", form, f'[environment]\nsource = "image"\nfile = "{ref}"\n'
            '[[objects]]\nshape = "sphere"\nmaterial = "plain"\n')  # fmt: skip
    add("mesh-file", "linked-file", '[[objects]]\nshape = "mesh"\nfile = "link.obj"\n')
    # glTF URIs
    for form, uri in {**_uri_forms(secret, "secret.bin"), "linked-file": "link.bin"}.items():
        _gltf(asset, f"buffer-{form}.gltf", uri, None)
        add("gltf-buffer", form, f'[[objects]]\nshape = "mesh"\nfile = "buffer-{form}.gltf"\n')
    for form, uri in {**_uri_forms(secret, "secret.png"), "linked-file": "link.png"}.items():
        _gltf(asset, f"image-{form}.gltf", None, uri)
        add("gltf-image", form, f'[[objects]]\nshape = "mesh"\nfile = "image-{form}.gltf"\n')
    data_png = "data:image/png;base64," + base64.b64encode(_png((9, 9, 200))).decode()
    _gltf(asset, "image-data.gltf", None, data_png)
    add("gltf-image", "data-uri", '[[objects]]\nshape = "mesh"\nfile = "image-data.gltf"\n',
        expect="rendered")  # fmt: skip
    # OBJ: mtllib and the MTL's maps
    tri = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
    for form, ref in _forms(secret, "secret.mtl").items():
        (asset / f"mtllib-{form}.obj").write_text(
            f"mtllib {ref}\n{tri}usemtl m\nf 1/1 2/2 3/3\n", encoding="utf-8"
        )
        add("obj-mtllib", form, f'[[objects]]\nshape = "mesh"\nfile = "mtllib-{form}.obj"\n')
    for keyword in ("map_Kd", "norm", "map_Pr"):
        for form, ref in {**_forms(secret, "secret.png"), "linked-file": "link.png"}.items():
            stem = f"mtl-{keyword}-{form}"
            (asset / f"{stem}.mtl").write_text(
                f"newmtl m\nKd 1 1 1\n{keyword} -o 0 0 0 {ref}\n", encoding="utf-8"
            )
            (asset / f"{stem}.obj").write_text(
                f"mtllib {stem}.mtl\n{tri}usemtl m\nf 1/1 2/2 3/3\n", encoding="utf-8"
            )
            add("obj-map", f"{keyword}-{form}",
                f'[[objects]]\nshape = "mesh"\nfile = "{stem}.obj"\n')  # fmt: skip
    # batch job files naming scenes outside their folder
    for form, ref in _forms(secret, "secret.toml").items():
        for kind in ("scene", "scenes"):
            job = asset / f"job-{kind}-{form}.toml"
            if kind == "scene":
                job.write_text(f'scene = "{ref}"\norbit = {{ frames = 1 }}\n', encoding="utf-8")
            else:
                job.write_text(f'scenes = ["{ref}"]\n', encoding="utf-8")
            out = asset / f"job-{kind}-{form}-out"
            argv = ["batch", str(job), "-o", str(out), "-q", "--backend", "egl"]
            cases.append(Case(f"batch-{kind}-{form}", argv, str(asset),
                              [str(out / "frame-0000.png"), str(out / "0000-secret.png")],
                              str(secret), "refused"))  # fmt: skip
    return cases


def _allowed(layout: dict[str, Path]) -> list[Case]:
    """References into secret/ that render once --allow-path names it."""
    asset, secret = layout["asset"], layout["secret"]
    cases = []
    for case_id, body in (
        ("allowed-mesh", f'[[objects]]\nshape = "mesh"\nfile = "{secret / "secret.obj"}"\n'),
        ("allowed-texture", '[materials.m]\nbase_color_map = "../secret/secret.png"\n'
         '[[objects]]\nshape = "sphere"\nmaterial = "m"\n'),
        ("allowed-buffer", '[[objects]]\nshape = "mesh"\nfile = "buffer-parent.gltf"\n'),
        ("allowed-environment", '[environment]\nsource = "image"\nfile = "link.hdr"\n'
         '[[objects]]\nshape = "sphere"\nmaterial = "plain"\n'),
    ):  # fmt: skip
        scene = _scene(asset, f"{case_id}.toml", body)
        cases.append(_render_case(case_id, layout, scene, "rendered", allow=True))
    return cases


def test_references_outside_the_folder_are_refused(layout: dict[str, Path], tmp_path: Path) -> None:
    cases = _cases(layout) + _allowed(layout)
    assert len(cases) >= 95
    outcomes = run_cases(cases, tmp_path)
    found = escapes(cases, outcomes)
    assert not found, f"{len(found)} of {len(cases)} escaped:\n" + "\n".join(found)


def test_a_refused_path_says_nothing_about_its_target(
    layout: dict[str, Path], tmp_path: Path
) -> None:
    """The error for a reference to an existing secret file and to a missing one differ
    only in the name as written: neither size, bytes nor existence shows."""
    asset, secret = layout["asset"], layout["secret"]
    cases = []
    for name in ("secret.png", "missing.png"):
        for form, ref in _forms(secret, name).items():
            scene = _scene(asset, f"tell-{form}-{name}.toml", '[materials.m]\n'
                           f'base_color_map = "{ref}"\n[[objects]]\nshape = "sphere"\n'
                           'material = "m"\n')  # fmt: skip
            cases.append(_render_case(f"tell-{form}-{name}", layout, scene, "refused"))
    for name in ("secret.bin", "missing.bin"):
        for form, uri in _uri_forms(secret, name).items():
            _gltf(asset, f"tell-{form}-{name}.gltf", uri, None)
            scene = _scene(asset, f"tell-gltf-{form}-{name}.toml", '[[objects]]\n'
                           f'shape = "mesh"\nfile = "tell-{form}-{name}.gltf"\n')  # fmt: skip
            cases.append(_render_case(f"tell-gltf-{form}-{name}", layout, scene, "refused"))
    outcomes = run_cases(cases, tmp_path)
    assert not escapes(cases, outcomes)
    messages: dict[str, set[str]] = {}
    for case in cases:
        line = outcomes[case.id].stderr.strip()
        generic = line.replace(case.id, "CASE").replace("missing", "secret")
        messages.setdefault(case.id.replace("missing", "secret"), set()).add(generic)
    for case_id, seen in messages.items():
        assert len(seen) == 1, f"{case_id}: the error tells the two targets apart: {seen}"


def test_bytes_of_a_secret_never_appear(layout: dict[str, Path]) -> None:
    """The canary itself: the secret files really hold SECRET, so a case that read one
    and quoted it would be caught."""
    secret = layout["secret"]
    assert SECRET.encode() in (secret / "secret.bin").read_bytes()
    assert SECRET.encode() in (secret / "secret.png").read_bytes()
    assert np.frombuffer((secret / "secret.hdr").read_bytes()[-4:], np.uint8)[3] == 129


def test_the_api_is_strict_by_default(layout: dict[str, Path]) -> None:
    """A scene dict (what a service builds from a request) reads only its base_dir, as a
    file reads its folder; allow_paths widens it, as --allow-path does."""
    from app.api import scene_from
    from app.errors import InputError
    from app.scene.geometry import build_parts

    asset, secret = layout["asset"], layout["secret"]
    data = {
        "materials": {"m": {"base_color_map": str(secret / "secret.png")}},
        "objects": [{"shape": "sphere", "material": "m"}],
    }
    with pytest.raises(InputError, match="is outside the folder") as err:
        scene_from(data, base_dir=asset)
    assert SECRET not in str(err.value)
    loaded = scene_from(data, base_dir=asset, allow_paths=[secret])
    assert build_parts(loaded)[0].layers[0].maps["base_color"].pixels[0, 0, 0] == 250
    with pytest.raises(InputError, match="past the limit"):
        big = {"render": {"width": 4096, "height": 4096}, **data}
        from app.gl.context import create_context
        from app.render.renderer import Renderer

        gl = create_context("egl")
        try:
            Renderer(gl, scene_from(big, base_dir=asset, allow_paths=[secret], max_memory=1 << 28))
        finally:
            gl.release()
