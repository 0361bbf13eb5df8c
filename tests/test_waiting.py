"""Work the main thread does ahead while it waits (app/waiting.py): what runs at a wait,
what does not, an error kept for the caller, the block's end, items offered while a block
lasts; and ``pbs render``'s GL context started and a map's chain drawn while the scene's
reader waits for a map's levels, with the same image."""

from __future__ import annotations

import io
import threading
import time
from concurrent.futures import Future
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from PIL import Image

from app import waiting
from app.waiting import Ahead, AheadEach, ahead, before_waiting, offer
from tests.gltf_builder import GltfBuilder


def test_work_done_at_a_main_thread_wait_one_piece_at_a_time() -> None:
    """A wait for a future that is not done does the declared work, oldest first, and
    stops once the future is done; ``get`` then takes the value without making it again."""
    future: Future = Future()
    made: list[str] = []

    def first() -> str:
        made.append("first")
        future.set_result(None)  # what the wait waited for is done meanwhile
        return "one"

    later = Ahead(lambda: made.append("later") or "two")
    with ahead(Ahead(first), later):
        work = waiting._PENDING[0]
        before_waiting(future)
        assert made == ["first"]  # the future was done: the second piece waits its turn
        assert work.get() == "one" and made == ["first"]
        before_waiting(Future())  # another wait does it
        assert made == ["first", "later"] and later.get() == "two"


def test_nothing_done_where_there_is_no_wait() -> None:
    """A future already done, no future, or a wait on another thread does none of it: the
    value is made where ``get`` asks for it."""
    made: list[int] = []
    work = Ahead(lambda: made.append(1) or 7)
    done: Future = Future()
    done.set_result(None)
    with ahead(work):
        before_waiting(done)
        before_waiting(None)
        helper = threading.Thread(target=before_waiting, args=(Future(),))
        helper.start()
        helper.join()
        assert made == []
        assert work.get() == 7 and made == [1]
        before_waiting(Future())
        assert made == [1]  # made once


def test_work_done_by_the_thread_that_declared_it() -> None:
    """Work declared on a helper thread is done at that thread's wait, not at the main
    thread's (its value, a GL context, is the helper's to use)."""
    made: list[str] = []
    work = Ahead(lambda: made.append(threading.current_thread().name) or 1)

    def helper() -> None:
        with ahead(work):
            declared.set()
            assert go.wait(10.0)
            before_waiting(Future())

    declared, go = threading.Event(), threading.Event()
    thread = threading.Thread(target=helper, name="declaring")
    thread.start()
    assert declared.wait(10.0)
    before_waiting(Future())  # the main thread's wait: not its work
    assert made == []
    go.set()
    thread.join(10.0)
    assert made == ["declaring"]


def test_error_kept_for_the_caller() -> None:
    """An exception the work raises at a wait is not raised there but by ``get``."""

    def fails() -> None:
        raise ValueError("no device 3")

    work = Ahead(fails)
    with ahead(work):
        before_waiting(Future())  # no exception here
        with pytest.raises(ValueError, match="no device 3"):
            work.get()


def test_block_end_drops_the_work_and_releases_what_was_not_taken() -> None:
    """Work not done by the block's end is never done by a later wait; a value made
    ahead and never taken (a render refused after its context started) is released; one
    taken is its taker's."""
    released: list[str] = []
    made: list[str] = []
    taken = Ahead(lambda: "kept", release=released.append)
    untaken = Ahead(lambda: "spare", release=released.append)
    never = Ahead(lambda: made.append("never"), release=released.append)
    with ahead(taken, untaken):
        before_waiting(Future())
        assert taken.get() == "kept"
    with ahead(never):
        pass
    before_waiting(Future())
    assert released == ["spare"] and made == [] and waiting._PENDING == []


def test_lent_value_is_released_where_nothing_takes_it() -> None:
    """``lend`` makes the value for other work done ahead without taking it: the block's
    end releases it where nothing took it after, and a ready work is one not made."""
    released: list[str] = []
    work = Ahead(lambda: "context", release=released.append)
    with ahead(work):
        assert work.ready() and not work.made
        assert work.lend() == "context"
        assert not work.ready() and work.made
        before_waiting(Future())  # made already: not made again
    assert released == ["context"]


def test_items_offered_are_done_at_the_declaring_threads_waits() -> None:
    """Items offered under a topic while a block lasts are done at a wait of the thread
    that declared the work, oldest first; not at another thread's wait, nor where nothing
    was offered; one whose handling raises is left to its caller; another topic's items,
    those offered outside the block and those left at its end are never done."""
    done: list[str] = []

    def handle(item: str) -> None:
        if item == "broken":
            raise RuntimeError("left to the caller")
        done.append(item)

    each = AheadEach("maps", handle)
    offer("maps", "before")  # no block: nobody takes it
    with ahead(each):
        before_waiting(Future())
        assert done == [] and not each.ready()
        for item in ("first", "broken", "second"):
            offer("maps", item)
        offer("lights", "elsewhere")
        helper = threading.Thread(target=before_waiting, args=(Future(),))
        helper.start()
        helper.join()
        assert done == [] and each.ready()
        before_waiting(Future())
        assert done == ["first", "second"] and not each.ready()
        offer("maps", "left")
    before_waiting(Future())
    assert done == ["first", "second"] and waiting._PENDING == []


def _colour_gltf(folder: Path, seed: int, chain: bool = False) -> Path:
    """A quad whose base colour is a 256^2 PNG of random texels (bytes no other render of
    this process decodes, so its levels are made here); ``chain``: with a normal map (its
    normals in the upper hemisphere, spread alike in every direction: the ``variance``
    chain the GL draws) and a metallic-roughness map of its size."""
    rng = np.random.default_rng(seed)
    b = GltfBuilder()
    for name in ("colour", "normal", "rough") if chain else ("colour",):
        texels = rng.integers(0, 256, (256, 256, 3), np.uint8)
        if name == "normal":
            texels[..., 2] = rng.integers(200, 256, (256, 256), np.uint8)
        encoded = io.BytesIO()
        Image.fromarray(texels).save(encoded, format="PNG")
        (folder / f"{name}.png").write_bytes(encoded.getvalue())
        b.doc.images.append(pygltflib.Image(uri=f"{name}.png"))
        b.doc.textures.append(pygltflib.Texture(source=len(b.doc.images) - 1))
    pbr = pygltflib.PbrMetallicRoughness(baseColorTexture=pygltflib.TextureInfo(index=0))
    material = pygltflib.Material(pbrMetallicRoughness=pbr)
    if chain:
        pbr.metallicRoughnessTexture = pygltflib.TextureInfo(index=2)
        material.normalTexture = pygltflib.NormalMaterialTexture(index=1)
    b.quad(material=b.material(material))
    return b.save(folder / "model.gltf")


def _renders_ahead_and_after(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, events: list[str], seed: int, chain: bool
) -> list[np.ndarray]:
    """``pbs render`` of ``_colour_gltf`` whose base colour's levels are slow (the scene's
    reader waits for them: the exposure meter reads them), once with the work declared
    ahead done at the reader's waits and once with no wait doing it; ``events`` gets
    "scene read" once the scene is read, beside the caller's own events. Returns each
    render's (events, PNG), ahead first."""
    from app import cli
    from app.scene import sources
    from app.textures import early, maps

    scene_from, box = sources.scene_from, maps.srgb_box_levels
    making = threading.Event()

    def slow_levels(level0: np.ndarray) -> list[np.ndarray]:
        making.set()
        time.sleep(0.5)
        return box(level0)

    def read(*args, **kwargs):
        # the reader comes once the early thread is making the levels (in a new process
        # its imports take longer than the decode), so that it waits for them
        assert making.wait(10.0)
        loaded = scene_from(*args, **kwargs)
        events.append("scene read")
        return loaded

    monkeypatch.setattr(maps, "srgb_box_levels", slow_levels)
    monkeypatch.setattr(sources, "scene_from", read)
    made = []
    for name, work_ahead in (("ahead", True), ("after", False)):
        folder = tmp_path / name
        folder.mkdir()
        path = _colour_gltf(folder, seed, chain=chain)
        monkeypatch.setenv("PBS_CACHE_DIR", str(folder / "cache"))
        making.clear()
        monkeypatch.setattr(early, "_TAKEN", set())  # the same bytes decode early again
        if not work_ahead:  # no wait of the texture layer does the work
            for module in (early, maps, waiting):
                monkeypatch.setattr(module, "before_waiting", lambda future: None)
        events.clear()
        out = folder / "out.png"
        assert cli.main(["render", str(path), "-o", str(out), "--size", "48x40", "-q"]) == 0
        made.append((list(events), np.asarray(Image.open(out))))
    return made


def test_render_starts_its_context_while_the_scene_waits(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``pbs render MODEL`` whose base colour's levels are slow: the GL context is made
    while the scene's reader waits for them (the exposure meter reads them), before the
    scene is read, and the PNG is the one made without working ahead."""
    from app import cli

    events: list[str] = []
    context = cli._context
    monkeypatch.setattr(cli, "_context", lambda args: events.append("context") or context(args))
    (ahead_events, ahead_png), (after_events, after_png) = _renders_ahead_and_after(
        tmp_path, monkeypatch, events, 29, chain=False
    )
    assert ahead_events == ["context", "scene read"]
    assert after_events == ["scene read", "context"]
    np.testing.assert_array_equal(ahead_png, after_png)


def test_render_draws_a_maps_chain_while_the_scene_waits(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``pbs render MODEL`` with a normal map whose chain the GL draws, and slow base
    colour levels: the chain is drawn while the scene's reader waits for them (app/cli.py
    ``_draw_chain_ahead``), and the renderer's upload takes it; the PNG is the one made
    with the chain drawn in the renderer's set-up."""
    from app.render import normal_chain

    events: list[str] = []
    build = normal_chain.build_chain
    monkeypatch.setattr(
        normal_chain, "build_chain", lambda *a, **k: events.append("chain") or build(*a, **k)
    )
    (ahead_events, ahead_png), (after_events, after_png) = _renders_ahead_and_after(
        tmp_path, monkeypatch, events, 31, chain=True
    )
    assert ahead_events == ["chain", "scene read"]
    assert after_events == ["scene read", "chain"]
    np.testing.assert_array_equal(ahead_png, after_png)
