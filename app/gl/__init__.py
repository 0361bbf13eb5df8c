"""OpenGL plumbing: headless contexts and the GLSL source assembler."""
