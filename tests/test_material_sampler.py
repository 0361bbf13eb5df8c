"""The bundled glTF sample asset (app/assets/material_sampler.py): the checked-in
scenes/meshes/material_sampler.glb is what its generator writes, stays small, and every
core material feature it is there to show reaches the scene's parts."""

from __future__ import annotations

import io
import json
import struct

import numpy as np
from PIL import Image

from app.assets.material_sampler import OUT, build, uv_sphere
from app.resources import scenes_dir
from app.scene.geometry import build_parts
from app.scene.loader import load_scene


def _glb_content(data: bytes) -> tuple[dict, list[bytes], list[np.ndarray]]:
    """A GLB as what it means rather than its bytes: the JSON without byte offsets and
    lengths, the bytes of every buffer view that is not an image, and every image decoded
    (another zlib may compress the same PNG pixels to other bytes)."""
    length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20 : 20 + length])
    start = 20 + length + 8  # the BIN chunk's data
    images = {img["bufferView"] for img in doc.get("images", [])}
    blobs, pixels = [], []
    for i, view in enumerate(doc["bufferViews"]):
        chunk = data[start + view.get("byteOffset", 0) :][: view["byteLength"]]
        if i in images:
            pixels.append(np.asarray(Image.open(io.BytesIO(chunk))))
        else:
            blobs.append(chunk)
        view.pop("byteOffset", None)
        view.pop("byteLength")
    for buffer in doc["buffers"]:
        buffer.pop("byteLength")
    return doc, blobs, pixels


def test_bundled_glb_is_its_generator_output():
    """The same document, geometry and texels: regenerate with ``python -m
    app.assets.material_sampler`` after changing the generator (fails with any texture,
    mesh or material edited in one place and not the other)."""
    data = build()
    assert len(data) < 300_000
    if OUT.read_bytes() == data:
        return
    ours, theirs = _glb_content(OUT.read_bytes()), _glb_content(data)
    assert ours[0] == theirs[0] and ours[1] == theirs[1]
    assert len(ours[2]) == len(theirs[2])
    for a, b in zip(ours[2], theirs[2], strict=True):
        np.testing.assert_array_equal(a, b)


def test_sampler_scene_parts_carry_every_feature():
    """scenes/gltf_material_sampler.toml's mesh object: the sphere has base colour,
    metallic, normal (with roughness) and occlusion maps; the panel an emissive map and
    radiance emissiveFactor x strength 4; the grate and the leaf are alpha-masked at 0.5
    and two-sided; the sphere and the panel are culled single-sided surfaces."""
    parts = [p for p in build_parts(load_scene(scenes_dir() / "gltf_material_sampler.toml"))]
    meshes = [p for p in parts if p.object_index == 1]
    assert len(meshes) == 4
    sphere, panel, grate, leaf = (p.layers[0] for p in meshes)
    assert {"base_color", "normal_roughness", "metallic", "occlusion"} <= set(sphere.maps)
    assert sphere.normal_mapped and sphere.occlusion_strength == 1.0
    assert "emissive" in panel.maps and panel.emissive == (4.0, 4.0, 4.0)
    for layer in (grate, leaf):
        assert layer.alpha_mode == "mask" and layer.alpha_cutoff == 0.5
    assert [p.closed for p in meshes] == [True, True, False, False]


def test_uv_sphere_is_a_closed_outward_sphere():
    """Every vertex at the radius with its normal pointing out, UVs in [0, 1], and each
    triangle wound counter-clockwise seen from outside (its face normal points out)."""
    positions, normals, uv, indices = uv_sphere(0.5, 6, 12)
    np.testing.assert_allclose(np.linalg.norm(positions, axis=1), 0.5, rtol=1e-6)
    np.testing.assert_allclose(positions, 0.5 * normals, atol=1e-6)
    assert uv.min() >= 0.0 and uv.max() <= 1.0
    tri = positions[indices.reshape(-1, 3)].astype(np.float64)
    face = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    centre = tri.mean(axis=1)
    big = np.linalg.norm(face, axis=1) > 1e-9  # the poles' degenerate triangles aside
    assert big.sum() > 0.8 * len(face)
    assert (np.einsum("ij,ij->i", face[big], centre[big]) > 0).all()
