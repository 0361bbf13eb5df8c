// G-buffer pass, fragment stage: writes the material parameters of the nearest surface.
// Layout (docs/gbuffer.md):
//   RT0 g_albedo : base_color.rgb (linear), metallic
//   RT1 g_normal : octahedral normal (2), perceptual roughness, dielectric F0
//   RT2 g_depth  : RG32F linear view depth in metres (0 = no surface; the world position
//                  is reconstructed from it), material id (an exact integer).
//                  A DEPTH24 buffer does the z-test.
//   RT3 g_tangent: octahedral tangent (2), anisotropy, 0; only with GBUFFER_TANGENT (a
//                  material of the scene is anisotropic: nothing else reads a tangent)
#include "common/constants.glsl"
#include "common/encoding.glsl"
#include "material/layers.glsl"

#ifndef GBUFFER_TANGENT
#define GBUFFER_TANGENT 1
#endif

in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
in float v_view_depth;

layout(location = 0) out vec4 g_albedo;
layout(location = 1) out vec4 g_normal;
layout(location = 2) out vec2 g_depth;
#if GBUFFER_TANGENT
layout(location = 3) out vec4 g_tangent;
#endif

void main() {
    MaterialSample m = sample_material(v_normal, v_tangent, v_uv, gl_FrontFacing);
    Layer l = m.layer;
    g_albedo = vec4(l.base_color, l.metallic);
    g_normal = vec4(oct_encode(m.n), l.perceptual_roughness, l.f0);
    g_depth = vec2(v_view_depth, m.material_id);
#if GBUFFER_TANGENT
    // Interpolation shortens the tangent and may tilt it off the surface; the lighting
    // pass re-orthonormalises it against n, so only its direction matters here.
    g_tangent = vec4(oct_encode(m.t), l.anisotropy, 0.0);
#endif
}
