"""What the viewer's panels and its walkthrough lesson may read and do: ``ViewerHost``.

The window (app/viewer/window.py) builds the panels (app/viewer/panels.py) and the lesson
(app/viewer/lesson.py), and both drive it back: they read the edited scene and call
``edit``, ``compare``, ``open_scene``. They name this protocol, which the window's
``Viewer`` satisfies, instead of ``Viewer`` itself, so that neither imports the window: the
viewer's modules import one way (window -> panels -> lesson -> host), with no loop even
through annotations. The records the three share (``Selection``, ``ViewerState``) live
here for the same reason.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    import moderngl

    from app.gl.context import GLContext
    from app.render.compare import Comparison
    from app.render.renderer import Renderer
    from app.scene.model import Camera, Scene
    from app.viewer.document import SceneDocument


@dataclass
class Selection:
    """What a click picked: an object (index into scene.objects) and its material: a
    name in the scene's [materials], or, for a glTF file's own material, its key in the
    object's ``file_materials`` (app/scene/file_materials.py)."""

    object_index: int | None = None
    material: str | None = None
    file_material: str | None = None


@dataclass
class ViewerState:
    """The viewer's frame-to-frame state that the panels read and write."""

    last_input: float = 0.0
    dirty: bool = True  # the scene changed since the last render
    rendered_scale: int = 0  # the scale the last image was rendered at
    pending: list[dict[str, Any]] = field(default_factory=list)  # structural edits
    notice: str = ""
    error: str = ""  # shown in the Problems panel
    glsl_mtime: float = 0.0
    last_watch: float = 0.0
    frame_ms: dict[str, float] = field(default_factory=dict)


class ViewerHost(Protocol):
    """The window as its panels and lesson see it (``app.viewer.window.Viewer``)."""

    document: SceneDocument
    selection: Selection
    state: ViewerState
    gl: GLContext
    ctx: moderngl.Context
    renderer: Renderer
    comparison: Comparison | None
    compare_mode: str  # "split" or "difference"
    divider: float
    gain: float
    debug_view: str | None
    debug_light: int
    vsync: bool
    base_camera: Camera
    # The open walkthrough (app/viewer/lesson.py's ``Lesson``) or None; not typed as one,
    # since the lesson module names this protocol.
    lesson: Any

    @property
    def scene(self) -> Scene: ...

    @property
    def framebuffer_size(self) -> tuple[int, int]: ...

    @property
    def image_size(self) -> tuple[int, int]: ...

    def value(self, key: str, default: Any = None) -> Any: ...

    def edit(self, changes: dict[str, Any], *, defer: bool | None = None) -> bool: ...

    def touch(self) -> None: ...

    def reset_camera(self) -> None: ...

    def frame_selection(self) -> None: ...

    def add_light(self, kind: str) -> bool: ...

    def remove_light(self, index: int) -> bool: ...

    def compare(
        self,
        key: str,
        a: Any,
        b: Any,
        mode: str = "split",
        divider: float | None = 0.5,
        gain: float = 8.0,
    ) -> bool: ...

    def stop_compare(self) -> None: ...

    def set_divider(self, divider: float) -> None: ...

    def set_debug_view(self, view: str | None, light: int = 0) -> bool: ...

    def set_vsync(self, on: bool) -> None: ...

    def open_scene(self, path: Path) -> bool: ...

    def open_walkthrough(
        self, steps: list | None = None, lang: str | None = None, section: int = 1
    ) -> bool: ...

    def save_scene(self, path: Path | None = None) -> Path: ...

    def screenshot(self, path: Path | None = None, hdr: bool = False) -> Path: ...
