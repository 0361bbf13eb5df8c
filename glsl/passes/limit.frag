// Limit pass (the bench's `limit` variant): what the machine needs to evaluate LIMIT_COUNT
// light terms per pixel with nothing else in the way. The same G-buffer decode and light
// term as the lighting pass (light_term, lights/illumination.glsl), but no list walk: a
// loop of compile-time length over the pixel's own lights, whose indices were found on the
// CPU (app/bench/pairs.py) and uploaded untimed, 16 bits each, 8 per RGBA32UI texel
// (app/bench/limit.py). Pixels with fewer lights repeat a dark light (index LIMIT_LIGHTS
// - 1, out of range everywhere), so every pixel pays exactly LIMIT_COUNT terms.
//   L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+          (RTR4 sec. 9.4)
// LIMIT_FORM says where the lights' three texels live: 0 the light texture (texelFetch),
// 1 a uniform array, 2 a uniform block (app/bench/limit.py measures all three).
#include "brdf/brdf.glsl"
#include "gbuffer/decode.glsl"
#include "lights/illumination.glsl"

uniform sampler2D u_materials;      // RGBA32F, MATERIAL_TEXELS per material (app/common/material_fields.py)
uniform usampler2D u_pixel_lights;  // RGBA32UI: LIMIT_TEXELS texels per pixel
uniform vec3 u_camera_pos;
uniform mat3 u_camera_to_world;
uniform vec2 u_tan_half_fov;        // tan(fov_y/2) * aspect, tan(fov_y/2)

#if LIMIT_FORM == 0
uniform sampler2D u_lights;         // RGBA32F, 3 texels per light, one light per row
#elif LIMIT_FORM == 1
uniform vec4 u_light_vec[3 * LIMIT_LIGHTS];
#else
layout(std140) uniform LimitLights {
    vec4 u_light_block[3 * LIMIT_LIGHTS];
};
#endif

// Light i, from where LIMIT_FORM keeps it.
PunctualLight limit_light(int i) {
#if LIMIT_FORM == 0
    return fetch_light(u_lights, i);
#elif LIMIT_FORM == 1
    return unpack_light(u_light_vec[3 * i], u_light_vec[3 * i + 1], u_light_vec[3 * i + 2]);
#else
    return unpack_light(u_light_block[3 * i], u_light_block[3 * i + 1], u_light_block[3 * i + 2]);
#endif
}

out vec4 frag_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    ShadingPoint sp = decode_gbuffer(gl_FragCoord.xy, u_materials, u_camera_pos,
                                     u_camera_to_world, u_tan_half_fov);
    uvec4 words[LIMIT_TEXELS];
    for (int k = 0; k < LIMIT_TEXELS; ++k) {
        words[k] = texelFetch(u_pixel_lights, ivec2(px.x * LIMIT_TEXELS + k, px.y), 0);
    }
    vec3 Lo = vec3(0.0);
    BrdfView bv = brdf_view(sp);   // once per point, as the lighting pass's sum_lights
    for (int j = 0; j < LIMIT_COUNT; ++j) {  // constant trip count: unrolled
        uint word = words[j / 8][(j / 2) % 4];
        int i = int((word >> uint(16 * (j % 2))) & 0xFFFFu);
#if LIMIT_LOCAL_ONLY  // no directional light: the culled pass's local_light_term
        Lo += local_light_term(limit_light(i), i, sp, bv);
#else
        Lo += light_term(limit_light(i), i, sp, bv);
#endif
    }
    frag_color = vec4(PI * Lo, 1.0);
}
