"""The classroom walkthrough: one step per section of RTR4 chapter 9, kept as data.

A step file (``walkthrough/NN-slug.toml``, docs/walkthrough.md) names its scenes, the
labels drawn on them, its text for students in English and Korean, its equations
(LaTeX), prepared A/B comparisons, parameter sweeps and BRDF plots.

- ``model``: the step format (pydantic) and the loader, ``load_step`` and
  ``load_walkthrough``; a broken step is one ``InputError`` naming the file and the key.
- ``labels``: fonts found on the system and object labels drawn under each silhouette.
- ``mathsvg`` and ``markup``: LaTeX to inline SVG with matplotlib's mathtext (no network,
  no LaTeX install) and the text's small Markdown subset to HTML.
- ``build``: every step's images rendered headless, the offline HTML handout and its
  Markdown version (``pbs walkthrough``).
- ``browser``: headless Chromium driven over the DevTools protocol (the handout's checks
  and its screenshot).

Layer: above ``app.brdf`` (its plots), below ``app.viewer`` (which shows the steps:
``app.viewer.lesson``).
"""
