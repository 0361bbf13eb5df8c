// G-buffer pass, fragment stage: writes the material parameters of the nearest surface.
// Layout (docs/gbuffer.md):
//   RT0 g_albedo : base_color.rgb (linear), metallic
//   RT1 g_normal : octahedral normal (2), perceptual roughness, dielectric F0
//   RT2 g_depth  : R32F linear view depth in metres (0 = no surface); the world
//                  position is reconstructed from it. A DEPTH24 buffer does the z-test.
//   RT3 g_tangent: octahedral tangent (2), anisotropy, material id (exact integer)
#include "common/constants.glsl"
#include "common/encoding.glsl"
#include "material/layers.glsl"

in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
in float v_view_depth;

layout(location = 0) out vec4 g_albedo;
layout(location = 1) out vec4 g_normal;
layout(location = 2) out float g_depth;
layout(location = 3) out vec4 g_tangent;

void main() {
    MaterialSample m = sample_material(v_normal, v_tangent, v_uv, gl_FrontFacing);
    Layer l = m.layer;
    g_albedo = vec4(l.base_color, l.metallic);
    g_normal = vec4(oct_encode(m.n), l.perceptual_roughness, l.f0);
    g_depth = v_view_depth;
    // Interpolation shortens the tangent and may tilt it off the surface; the lighting
    // pass re-orthonormalises it against n, so only its direction matters here.
    g_tangent = vec4(oct_encode(m.t), l.anisotropy, m.material_id);
}
