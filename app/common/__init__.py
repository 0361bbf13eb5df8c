"""Definitions every layer shares: a leaf that imports nothing else of ``app``.

The renderer, the scene layer and the float64 twins (``app.reference``) all import these,
so nothing here is written twice:

* ``models``: the BRDF model names of each term, a material's ``Model`` and ``ModelParams``,
  the material table's layout, and ``render.terms``;
* ``lights``: the light types and the typed record (``PunctualLight``) that the GLSL and
  the twin consume, and its texture layout;
* ``tonemaps``: the tone-map names;
* ``ior``: F0 <-> index of refraction;
* ``camera``: what the lighting pass needs of a camera (``CameraFrame``);
* ``gbuffer``: a G-buffer read back to the CPU (``GBufferData``);
* ``tables``: the shipped look-up tables (``data/``);
* ``glsl``: the ``#define``s generated from these names for every GLSL program.
"""
