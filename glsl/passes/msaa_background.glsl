// The radiance behind a sample of an edge pixel that sees no surface
// (render.antialiasing = "msaa", app/render/msaa.py; included by passes/lighting.frag
// under GBUFFER_SAMPLES): the frame's own background at this pixel where its centre saw
// none, else at the first of its 4 neighbours whose centre saw none (an environment
// background's radiance a pixel away), else u_msaa_background (the uniform background,
// RGBA; a transparent one is 0).
#ifndef PBS_MSAA_BACKGROUND_GLSL
#define PBS_MSAA_BACKGROUND_GLSL

#include "brdf/material.glsl"

uniform sampler2D u_msaa_hdr;           // the frame's HDR image, shaded at pixel centres
uniform sampler2D u_msaa_centre_depth;  // the frame's RT2 (view depth 0: no surface)
uniform vec4 u_msaa_background;

vec4 msaa_background(ivec2 px) {
    ivec2 last = textureSize(u_msaa_centre_depth, 0) - 1;
    ivec2 steps[5] = ivec2[5](ivec2(0), ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
    for (int i = 0; i < 5; ++i) {
        ivec2 q = clamp(px + steps[i], ivec2(0), last);
        float z = texelFetch(u_msaa_centre_depth, q, 0).r;
        if (!(is_finite(z) && z > 0.0)) return texelFetch(u_msaa_hdr, q, 0);
    }
    return u_msaa_background;
}

#endif
