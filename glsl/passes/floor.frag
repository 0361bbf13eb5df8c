// Floor pass (the bench's lower bound): the lighting pass's per-light term evaluated exactly
// once per (pixel, light in range) pair and nothing else. The pairs were found on the CPU,
// exactly, from the read-back G-buffer (app/bench/pairs.py) and uploaded untimed as one
// light mask per pixel; this pass decodes the G-buffer as the lighting pass does and walks
// its pixel's mask with the lighting pass's own loop, where the tiled lighting pass walks
// its tile's mask, lights in range of the pixel or not.
//   L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+          (seed section 4)
#include "brdf/brdf.glsl"
#include "common/encoding.glsl"
#include "common/position.glsl"
#include "lights/tiles.glsl"
#include "lights/illumination.glsl"

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
uniform usampler2D u_pixel_masks;  // RGBA32UI: TILE_QUADS texels per pixel (app/bench/floor.py)
uniform vec3 u_camera_pos;
uniform mat3 u_camera_to_world;
uniform vec2 u_tan_half_fov;     // tan(fov_y/2) * aspect, tan(fov_y/2)

out vec4 frag_color;

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

    vec3 Lo = add_masked_lights(vec3(0.0), u_pixel_masks, px, u_lights, 0, s, params, n, t,
                                p, v);
    frag_color = vec4(PI * Lo, 1.0);
}
