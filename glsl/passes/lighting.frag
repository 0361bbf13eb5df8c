// Lighting pass: the illumination sum over a G-buffer, in linear HDR (with DISPLAY_OUT,
// already exposed, tone mapped and sRGB encoded: the display image).
//   L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+          (RTR4 sec. 9.4)
// plus shadows, the environment's light and emission: lights/shading.glsl, shared with
// the blend pass (passes/forward.frag with ALPHA_BLEND).
#include "brdf/brdf.glsl"
#include "gbuffer/decode.glsl"
#include "lights/shading.glsl"
#include "post/tonemap.glsl"

uniform sampler2D u_materials;  // RGBA32F, MATERIAL_TEXELS per material (app/common/material_fields.py)
uniform vec3 u_camera_pos;
uniform mat3 u_camera_to_world;
uniform vec2 u_tan_half_fov;     // tan(fov_y/2) * aspect, tan(fov_y/2)

#ifndef DISPLAY_OUT
#define DISPLAY_OUT 0
#endif
#if DISPLAY_OUT
// The post pass fused in (app/render/renderer.py, Renderer.run_lighting): where nothing
// between lighting and post reads the HDR image, the pass writes the display image
// directly, with passes/post.frag's arithmetic on the same float32 radiance.
uniform float u_exposure;   // linear scale, 2^EV
#endif

#if DISPLAY_OUT && defined(HDR_OUT)
// The radiance as well, at the same pixels (render.antialiasing = "gbaa" mixes it at the
// silhouettes: app/render/renderer.py, Renderer.run_lighting).
layout(location = 0) out vec4 frag_color;
layout(location = 1) out vec4 hdr_color;
#else
out vec4 frag_color;
#endif

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    // Discards the background (and, with MODEL_GROUP, the other groups' pixels).
    ShadingPoint sp = decode_gbuffer(gl_FragCoord.xy, u_materials, u_camera_pos,
                                     u_camera_to_world, u_tan_half_fov);
#if GBUFFER_EMISSION
    vec4 emission = decode_emission(gl_FragCoord.xy);   // rgb emitted, a occlusion
#else
    vec4 emission = vec4(0.0, 0.0, 0.0, 1.0);
#endif
#ifdef TILE_SIZE
    ivec2 tile = px / TILE_SIZE;
#else
    ivec2 tile = px;
#endif
#if SHADOWS && defined(SHADOW_FACE_NORMAL)
    // a receiver's normal is mapped: the shadow lookup's offset along the plane the depths
    // give, not the mapped sp.n (elsewhere sp.n is the geometric normal)
    vec3 ng = face_normal(px, texelFetch(g_depth, px, 0).r, u_camera_to_world,
                          u_tan_half_fov, sp.v, sp.n);
#else
    vec3 ng = sp.n;
#endif
    vec3 L = surface_radiance(tile, emission, sp, ng);
#if DISPLAY_OUT
    frag_color = vec4(srgb_encode(tonemap_selected(L * u_exposure)), 1.0);
#ifdef HDR_OUT
    hdr_color = vec4(L, 1.0);
#endif
#else
    frag_color = vec4(L, 1.0);
#endif
}
