"""Twin of glsl/common/constants.glsl."""

import math

PI = math.pi
INV_PI = 1.0 / math.pi

# See glsl/common/constants.glsl for why these floors exist.
MIN_PERCEPTUAL_ROUGHNESS = 0.045
MIN_N_DOT_V = 1e-4
MIN_N_DOT_L = 1e-20
