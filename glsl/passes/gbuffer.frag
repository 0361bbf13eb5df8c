// G-buffer pass, fragment stage: writes the material parameters of the nearest surface.
// Layout (docs/gbuffer.md):
//   RT0 g_albedo : base_color.rgb (linear), metallic
//   RT1 g_normal : octahedral normal (2), perceptual roughness, dielectric F0
//   RT2 g_depth  : R32F linear view depth in metres (0 = no surface); the world
//                  position is reconstructed from it. A DEPTH24 buffer does the z-test.
//   RT3 g_tangent: octahedral tangent (2), anisotropy, material id (exact integer)
#include "common/constants.glsl"
#include "common/encoding.glsl"

in vec3 v_normal;
in vec2 v_uv;
in vec3 v_tangent;
in float v_view_depth;

uniform vec3 u_base_color;
uniform float u_metallic;
uniform float u_roughness;
uniform float u_f0;
uniform float u_anisotropy;
uniform float u_material_id;   // row of the lighting pass's material table

#ifdef MAT_BASE_COLOR_MAP
uniform sampler2D u_base_color_map;    // sRGB texture: sampled as linear by the GL
#endif
#ifdef MAT_METALLIC_ROUGHNESS_MAP
uniform sampler2D u_metallic_roughness_map;  // glTF: G = roughness, B = metallic
#endif

layout(location = 0) out vec4 g_albedo;
layout(location = 1) out vec4 g_normal;
layout(location = 2) out float g_depth;
layout(location = 3) out vec4 g_tangent;

void main() {
    vec3 base_color = u_base_color;
    float metallic = u_metallic;
    float roughness = u_roughness;
#ifdef MAT_BASE_COLOR_MAP
    base_color *= texture(u_base_color_map, v_uv).rgb;
#endif
#ifdef MAT_METALLIC_ROUGHNESS_MAP
    vec4 mr = texture(u_metallic_roughness_map, v_uv);
    roughness *= mr.g;
    metallic *= mr.b;
#endif
    // Two-sided: a back face seen through an open mesh or under a plane is shaded
    // with the normal turned towards the viewer.
    vec3 n = normalize(gl_FrontFacing ? v_normal : -v_normal);
    g_albedo = vec4(base_color, metallic);
    g_normal = vec4(oct_encode(n), roughness, u_f0);
    g_depth = v_view_depth;
    // Interpolation shortens the tangent and may tilt it off the surface; the lighting
    // pass re-orthonormalises it against n, so only its direction matters here.
    vec3 t = v_tangent;
    float t_len = length(t);
    g_tangent = vec4(oct_encode(t_len > 0.0 ? t / t_len : n), u_anisotropy, u_material_id);
}
