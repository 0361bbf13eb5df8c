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
#if !DISPLAY_OUT && !defined(GBUFFER_SAMPLES)
// The background radiance (RGBA) of a pixel the z-buffer gives a surface whose decoded
// depth is none (not finite or not positive: decode_gbuffer's test); the HDR image is not
// cleared first (app/render/lighting.py, LightingPass.run: the pixels without a z are
// passes/hdr_background.frag's), so such a pixel is written here, not discarded.
uniform vec4 u_background;
#endif

#ifdef GBUFFER_SAMPLES
// render.antialiasing = "msaa" (app/render/msaa.py): the G-buffer is multisampled and
// this program shades an edge pixel once per sample (the decode reads sample
// gbuffer_sample); a sample that sees no surface takes msaa_background's radiance.
#include "passes/msaa_background.glsl"
#endif

// The radiance of the G-buffer's surface at window position frag_coord (its pixel's
// centre; under GBUFFER_SAMPLES the surface of sample gbuffer_sample). Discards where
// nothing was drawn (decode_gbuffer).
vec3 pixel_radiance(vec2 frag_coord) {
    ivec2 px = ivec2(frag_coord);
    // Discards the background (and, with MODEL_GROUP, the other groups' pixels).
    ShadingPoint sp = decode_gbuffer(frag_coord, u_materials, u_camera_pos,
                                     u_camera_to_world, u_tan_half_fov);
#if GBUFFER_EMISSION
    vec4 emission = decode_emission(frag_coord);   // rgb emitted, a occlusion
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
    vec3 ng = face_normal(px, texelFetch(g_depth, px, GBUFFER_SAMPLE).r, u_camera_to_world,
                          u_tan_half_fov, sp.v, sp.n);
#else
    vec3 ng = sp.n;
#endif
    return surface_radiance(tile, emission, sp, ng);
}

void main() {
#ifdef GBUFFER_SAMPLES
    // The mean of the samples' radiance (linear HDR RGBA, alpha the coverage: premultiplied
    // colour stays premultiplied). With MODEL_GROUP each group's program adds its own
    // samples' share (blended), the first group's the background samples' too.
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 sum = vec4(0.0);
    for (int s = 0; s < GBUFFER_SAMPLES; ++s) {
        gbuffer_sample = s;
        vec2 depth_id = texelFetch(g_depth, px, s).rg;
        if (!(is_finite(depth_id.x) && depth_id.x > 0.0)) {
#if !defined(MODEL_GROUP) || MODEL_GROUP == 0
            sum += msaa_background(px);
#endif
            continue;
        }
#ifdef MODEL_GROUP
        if (fetch_model_group(u_materials, int(depth_id.y)) != MODEL_GROUP) continue;
#endif
        sum += vec4(pixel_radiance(gl_FragCoord.xy), 1.0);
    }
    frag_color = sum / float(GBUFFER_SAMPLES);
#else
#if !DISPLAY_OUT
    float depth = texelFetch(g_depth, ivec2(gl_FragCoord.xy), GBUFFER_SAMPLE).r;
    if (!(is_finite(depth) && depth > 0.0)) {
        frag_color = u_background;
        return;
    }
#endif
    vec3 L = pixel_radiance(gl_FragCoord.xy);
#if DISPLAY_OUT
    frag_color = vec4(srgb_encode(tonemap_selected(L * u_exposure)), 1.0);
#ifdef HDR_OUT
    hdr_color = vec4(L, 1.0);
#endif
#else
    frag_color = vec4(L, 1.0);
#endif
#endif
}
