"""The desktop viewer (``pbs view``): a glfw window on the headless ``Renderer``, with Dear
ImGui panels; ``app.viewer.window.Viewer`` is its Python API (docs/viewer.md)."""
