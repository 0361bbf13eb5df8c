// Depth of field: each pixel's radiance scattered over its circle of confusion, written as
// a gather over a fixed disc of DOF_SAMPLES offsets (app/reference/dof.py explains the
// weights). Linear HDR in, linear HDR out: the blur happens before exposure and tone
// mapping, as a lens would. All four channels with the same weights: the HDR image is
// premultiplied by coverage (alpha), so a transparent background's alpha is the coverage
// blurred as the colour is (docs/architecture.md, "Alpha").
#include "common/constants.glsl"
#include "post/dof.glsl"

uniform sampler2D u_hdr;
uniform sampler2D u_depth;               // RG32F: view depth (0 = no surface), material id
uniform ivec2 u_offsets[DOF_SAMPLES];    // the twin's gather_offsets()
uniform float u_aperture;                // m
uniform float u_focus;                   // m
uniform float u_scale;                   // px per unit tangent
uniform float u_max_coc;                 // px
uniform float u_min_radius;              // px

out vec4 frag_color;

float depth_or_far(float z) {
    return (z > 0.0 && z < 3.0e38) ? z : 3.0e38;
}

float disc_weight(float r) {
    float rr = max(r, u_min_radius);
    return 1.0 / (PI * rr * rr);
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    ivec2 last = textureSize(u_hdr, 0) - 1;
    float z = texelFetch(u_depth, px, 0).r;
    float zi = depth_or_far(z);
    float ri = coc_radius(z, u_aperture, u_focus, u_scale, u_max_coc);
    float wi = disc_weight(ri);
    vec4 acc = texelFetch(u_hdr, px, 0) * wi;
    float total = wi;
    for (int k = 0; k < DOF_SAMPLES; ++k) {
        ivec2 o = u_offsets[k];
        ivec2 q = clamp(px + o, ivec2(0), last);
        float zj_raw = texelFetch(u_depth, q, 0).r;
        float rj = coc_radius(zj_raw, u_aperture, u_focus, u_scale, u_max_coc);
        if (depth_or_far(zj_raw) > zi) rj = min(rj, ri);   // behind: no bleeding forwards
        float wj = length(vec2(o)) <= rj ? disc_weight(rj) : 0.0;
        acc += texelFetch(u_hdr, q, 0) * wj;
        total += wj;
    }
    frag_color = acc / total;
}
