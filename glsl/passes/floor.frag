// Floor pass (the bench's lower bound): the lighting pass's BRDF evaluated exactly once per
// (pixel, light in range) pair and nothing else. The pairs were found on the CPU, exactly,
// from the read-back G-buffer (app/bench/pairs.py) and uploaded untimed; this pass only
// decodes the G-buffer and loops its pixel's list, where the tiled lighting pass loops
// every light of its tile's masks, in range of the pixel or not.
//   L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+          (seed section 4)
#include "common/constants.glsl"
#include "common/encoding.glsl"
#include "common/position.glsl"
#include "brdf/model.glsl"
#include "brdf/fresnel.glsl"
#include "brdf/ndf.glsl"
#include "brdf/masking.glsl"
#include "brdf/diffuse.glsl"
#include "brdf/multiscatter.glsl"
#include "brdf/specular.glsl"
#include "brdf/material.glsl"
#include "lights/punctual.glsl"

#ifndef PAIR_ROW
#define PAIR_ROW 4096   // texels per row of u_pair_lights
#endif

uniform sampler2D g_albedo;
uniform sampler2D g_normal;
uniform sampler2D g_depth;
#ifndef GBUFFER_TANGENT
#define GBUFFER_TANGENT 1
#endif
#if GBUFFER_TANGENT
uniform sampler2D g_tangent;    // only where a material is anisotropic (docs/gbuffer.md)
#endif
uniform sampler2D u_materials;     // RGBA32F, 4 texels per material (brdf/model.glsl)
uniform sampler2D u_lights;        // RGBA32F, 3 texels per light, one light per row
uniform usampler2D u_pair_ranges;  // RG32UI per pixel: (first pair, number of pairs)
uniform usampler2D u_pair_lights;  // R32UI: light index of each pair, PAIR_ROW per row
uniform vec3 u_camera_pos;
uniform mat3 u_camera_to_world;
uniform vec2 u_tan_half_fov;     // tan(fov_y/2) * aspect, tan(fov_y/2)

out vec4 frag_color;

// The lighting pass's per-light term (glsl/passes/lighting.frag).
vec3 light_contribution(int i, Surface s, ModelParams params, vec3 n, vec3 t, vec3 p, vec3 v) {
    vec3 l;
    vec3 c_light = light_at(fetch_light(u_lights, i), p, l);
    float NoL = dot(n, l);
    if (NoL <= 0.0) return vec3(0.0);          // (n.l)+ : lights behind the surface add nothing
    return brdf_eval(s, params, n, t, l, v) * c_light * NoL;
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec2 depth_id = texelFetch(g_depth, px, 0).rg;
    float depth = depth_id.x;
    // Nothing drawn (or a non-finite depth): the cleared background stays.
    if (!(is_finite(depth) && depth > 0.0)) discard;
    int material_id = int(depth_id.y);
#if GBUFFER_TANGENT
    vec4 c = texelFetch(g_tangent, px, 0);
#else
    vec4 c = vec4(0.0);   // no anisotropic material: anisotropy 0, the tangent unused
#endif
#ifdef MODEL_GROUP
    if (fetch_model_group(u_materials, material_id) != MODEL_GROUP) discard;
#endif
    vec4 a = texelFetch(g_albedo, px, 0);
    vec4 b = texelFetch(g_normal, px, 0);
    // The lighting pass's decoding, sanitising included (docs/stability.md).
    Surface s = sanitize_surface(Surface(a.rgb, a.a, b.b, b.a, c.b));
    ModelParams params = fetch_model_params(u_materials, material_id);
    vec3 t = oct_decode(c.rg);
    vec2 ndc_xy = (gl_FragCoord.xy / vec2(textureSize(g_depth, 0))) * 2.0 - 1.0;
    vec3 p = reconstruct_position(ndc_xy, depth, u_camera_pos, u_camera_to_world,
                                  u_tan_half_fov);
    vec3 v = normalize(u_camera_pos - p);
    vec3 n = sanitize_direction(oct_decode(b.rg), v);

    uvec2 range = texelFetch(u_pair_ranges, px, 0).xy;
    vec3 Lo = vec3(0.0);
    // Bottom-tested, like the lighting pass's loops: a top-tested loop would evaluate one
    // more (masked) light per pixel on llvmpipe (lighting.frag).
    uint k = range.x;
    if (range.y > 0u) do {
        int i = int(texelFetch(u_pair_lights, ivec2(int(k % uint(PAIR_ROW)),
                                                     int(k / uint(PAIR_ROW))), 0).r);
        Lo += light_contribution(i, s, params, n, t, p, v);
    } while (++k < range.x + range.y);
    frag_color = vec4(PI * Lo, 1.0);
}
