"""What an input may reach and what reading it may cost: ``InputPolicy`` and its ``Limits``.

A scene file, a model file, a job file or a scene built in Python names other files. By
default each reference must resolve (symlinks followed) inside the folder of the file that
makes it, or inside the project's bundled data; ``InputPolicy.allowed`` adds folders the
user chose (``--allow-path DIR``, ``allow_paths=`` in the API). Nothing else is ever
opened, so a downloaded asset cannot read ``../../.ssh/id_rsa`` or ``/etc/hostname``.

``Limits`` bounds the cost of one input before it is paid: every value is far above what
real assets use (docs/stability.md, "Limits", says why each one is what it is and which
real assets were measured against it) and far below what would take a machine down.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

from app.resources import bundled_dirs

GIB = 1 << 30
MIB = 1 << 20


@dataclass(frozen=True)
class Limits:
    """Upper bounds on one input; each refusal names the limit it hit."""

    # The memory one scene may take: the peak of its decoded meshes and textures as the
    # loaders build them (app/untrusted/budget.py), and what of them it keeps plus its
    # GPU resources (geometry, maps, render targets, shadow atlas: app/render/limits.py).
    # --max-memory changes it.
    max_memory: int = 4 * GIB
    # Bytes of one referenced file (a glTF buffer, an image, a mesh): checked against the
    # file's size before it is read.
    max_file_bytes: int = 1 * GIB
    # Bytes of one text file that is parsed whole (a scene, a job file, a walkthrough
    # step, an MTL file) and of one glTF JSON document.
    max_text_bytes: int = 16 * MIB
    max_json_bytes: int = 64 * MIB
    # Nesting depth of parsed JSON and TOML: scene files nest 4 deep, glTF 7.
    max_nesting: int = 64
    # glTF: entries of any one JSON array (nodes, accessors, images, a node's children,
    # ...) and the depth of the node hierarchy.
    max_entries: int = 65_536
    max_node_depth: int = 1_024
    # Drawn parts (a glTF primitive once per node that shows it, a mesh of an OBJ) and
    # triangles over all of them, instances counted each time they are drawn.
    max_parts: int = 16_384
    max_triangles: int = 1 << 25
    # Texels a side of one texture, and the width of an environment image (its height is
    # half of it).
    max_texture_side: int = 8_192
    max_environment_width: int = 8_192

    def with_memory(self, max_memory: int | None) -> Limits:
        """These limits with ``max_memory`` (None: unchanged)."""
        return self if max_memory is None else replace(self, max_memory=int(max_memory))


@dataclass(frozen=True)
class InputPolicy:
    """The folders references may reach beyond each referencing file's own, and the limits.

    ``allowed`` holds resolved folders; the bundled data (scenes, meshes, textures, the
    walkthrough's steps) is always allowed."""

    allowed: tuple[Path, ...] = ()
    limits: Limits = field(default_factory=Limits)

    @classmethod
    def from_options(
        cls,
        allow_paths: tuple[str | Path, ...] | list[str | Path] = (),
        max_memory: int | None = None,
    ) -> InputPolicy:
        """A policy from the command line's ``--allow-path`` folders and ``--max-memory``."""
        folders = tuple(Path(p).expanduser().resolve() for p in allow_paths)
        return cls(folders, Limits().with_memory(max_memory))

    def roots(self, referencing: Path) -> tuple[Path, ...]:
        """The folders a reference made by the file ``referencing`` may resolve into."""
        return (Path(referencing).resolve().parent, *self.allowed, *bundled_dirs())


DEFAULT_POLICY = InputPolicy()
