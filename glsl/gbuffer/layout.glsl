// The G-buffer's layout (docs/gbuffer.md), written by passes/gbuffer.frag and read back by
// gbuffer/decode.glsl:
//   RT0 g_base_color: base_color.rgb (linear), metallic. The base colour, not an albedo:
//                     the diffuse albedo of a dielectric but the F0 of a metal.
//   RT1 g_normal    : octahedral normal (2), perceptual roughness, dielectric F0
//   RT2 g_depth     : RG32F linear view depth in metres (0 = no surface; the world position
//                     is reconstructed from it), material id (an exact integer).
//                     A DEPTH24 buffer does the z-test.
//   RT3 g_tangent   : octahedral tangent (2), anisotropy, 0; only with GBUFFER_TANGENT (a
//                     material of the scene is anisotropic: nothing else reads a tangent)
//   RT4 g_coat_normal: octahedral clear-coat normal (2); only with GBUFFER_COAT_NORMAL (a
//                     coated material of the scene has a normal other than its base's: a
//                     coat over a normal-mapped base, or a coat normal map; RTR4 sec. 9.12)
#ifndef PBS_GBUFFER_LAYOUT_GLSL
#define PBS_GBUFFER_LAYOUT_GLSL

#ifndef GBUFFER_TANGENT
#define GBUFFER_TANGENT 1
#endif
#ifndef GBUFFER_COAT_NORMAL
#define GBUFFER_COAT_NORMAL 0
#endif

#endif
