"""pbs-lab: a physically based shading lab (Real-Time Rendering, "Physically Based Shading").

The package is laid out as the pipeline: ``app.scene`` (the scene model) ->
``app.render`` (G-buffer, lighting, post) -> ``app.output``; ``app.reference`` is the
float64 numpy twin of every GLSL shading function in ``glsl/``.
"""

__version__ = "0.1.0"
