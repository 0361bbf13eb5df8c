"""Float64 numpy twins of the GLSL shading code.

Each module mirrors one file of ``glsl/`` name for name (``glsl/brdf/ndf.glsl`` ->
``app.reference.ndf``) and each function carries the GLSL function's name and citation.
Vectors are arrays whose last axis has length 3; every function broadcasts.
"""
