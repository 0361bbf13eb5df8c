// Constants shared by every pass. Twin: app/reference/constants.py.
#ifndef PBS_CONSTANTS_GLSL
#define PBS_CONSTANTS_GLSL

const float PI = 3.14159265358979323846;
const float INV_PI = 0.31830988618379067154;

// Perceptual roughness floor. alpha = r^2 >= 0.045^2 = 2.0e-3 keeps the GGX peak
// 1/(pi alpha^2) below 8e4, far inside float32 and float16 range, and keeps a
// punctual highlight from collapsing below one pixel. (Filament uses the same floor.)
const float MIN_PERCEPTUAL_ROUGHNESS = 0.045;

// n.v floor. Interpolated and normal-mapped normals can face away from a visible
// pixel's view direction; clamping keeps 1/(n.v) bounded instead of flipping sign.
const float MIN_N_DOT_V = 1e-4;

#endif
