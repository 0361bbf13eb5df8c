"""The prepared-texture cache's keys and folders asked with the standard library alone
(app/textures/cache_keys.py): what a still render's early decode asks before numpy is
imported, the same answers as the cache's own."""

from __future__ import annotations

import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from app.textures import cache_keys
from app.textures.cache import PreparedCache, prepared_cache


def test_module_imports_no_numpy() -> None:
    """Importing the keys' module (and app.textures.early, which asks it) brings no numpy
    in: the early decodes do not wait for the main thread's import of it."""
    code = (
        "import sys; import app.textures.cache_keys, app.textures.early; "
        "print('numpy' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=Path(__file__).resolve().parents[1])  # fmt: skip
    assert out.stdout.strip() == "False"


def test_key_of_an_array_part() -> None:
    """An array part is keyed by its dtype, shape and bytes: another dtype or shape of the
    same bytes is another key, and an array and its bytes differ."""
    a = np.arange(6, dtype=np.uint8)
    key = cache_keys.entry_key("kind", (a,))
    assert key == cache_keys.entry_key("kind", (a.copy(),))
    assert key != cache_keys.entry_key("kind", (a.reshape(2, 3),))
    assert key != cache_keys.entry_key("kind", (a.astype(np.int8),))
    assert key != cache_keys.entry_key("kind", (a.tobytes(),))


def test_key_while_numpy_is_half_imported(monkeypatch: pytest.MonkeyPatch) -> None:
    """While another thread imports numpy, its module is in sys.modules without its names:
    a key of parts that hold no array is made all the same, and is the usual one."""
    parts = ("3.1", ("PNG", "ab"), 2, 0.5, None, b"xy")
    want = cache_keys.entry_key("decodes", parts)
    monkeypatch.setitem(sys.modules, "numpy", types.ModuleType("numpy"))
    assert cache_keys.entry_key("decodes", parts) == want


def test_held_on_disk_agrees_with_the_cache(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``held_on_disk`` answers what the process's cache's ``holds`` answers for an entry on
    disk, in a seed, or nowhere, and nothing with the cache turned off."""
    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("PBS_CACHE_SEED", str(tmp_path / "seed"))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    cache = prepared_cache()
    assert cache.directory == cache_keys.textures_directory()
    parts = ("a", 1)
    assert not cache_keys.held_on_disk("k", parts) and not cache.holds("k", parts)
    cache.arrays("k", parts, lambda: [np.zeros(3)])
    cache.flush()
    assert cache_keys.held_on_disk("k", parts) and cache.holds("k", parts)
    seed = PreparedCache(tmp_path / "seed")
    seed.arrays("s", parts, lambda: [np.ones(2)])
    seed.flush()
    assert cache_keys.held_on_disk("s", parts) and cache.holds("s", parts)
    monkeypatch.setenv("PBS_CACHE", "off")
    assert not cache_keys.held_on_disk("k", parts)
