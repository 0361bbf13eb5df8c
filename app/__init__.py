"""pbs-lab: a physically based shading lab (Real-Time Rendering 4th ed., chapter 9).

The package is laid out as the pipeline, each layer importing only those below it
(docs/architecture.md; tests/test_layers.py): ``app.common`` (shared definitions) ->
``app.reference`` (float64 twins of ``glsl/``) and ``app.gl`` (contexts, shader assembly)
-> ``app.textures`` -> ``app.scene`` -> ``app.frame`` -> ``app.render`` (G-buffer,
culling, lighting, post) -> the tools on top (``app.brdf``, ``app.bench``, ``app.cli``).
"""

__version__ = "0.1.0"
