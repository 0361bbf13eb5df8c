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

// n.l floor inside brdf_eval, for lights that are above the surface (n.l > 0) but only just:
// far below what a float32 direction resolves (dot() itself rounds by ~6e-8), so no lit
// result changes. Without it the Lambda/G2 path divides by 4 (n.l)(n.v), which for
// n.l = 1e-36, n.v = 1e-3 is a float32 denormal that the GPU flushes to 0: D G2 / 0 gave
// Inf (G2 > 0) or NaN (G2 = 0, when Lambda(n.l) had overflowed); and G2 ~ n.l made D G2
// underflow to 0 for n.l < 1e-29. At 1e-20 both have nine decades of headroom
// (tests/test_stability_brdf.py).
const float MIN_N_DOT_L = 1e-20;

#endif
