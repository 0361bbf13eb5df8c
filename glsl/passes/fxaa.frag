// A luma-edge filter of the display image, after the idea of T. Lottes, "FXAA 3.11"
// (NVIDIA, 2011): where the local contrast of luma is an edge, find its direction
// (horizontal or vertical, from the 3x3 second differences), walk along it both ways to
// its ends, and resample the pixel across the edge by the fraction of the pixel the
// nearer end says the edge covers; a sub-pixel term blends single-pixel features (a
// highlight, a thin silhouette) with their neighbourhood. Written for this project.
// Two draws (app/render/antialias.py FxaaPass), after a copy of the image (the filter's
// input): FXAA_BLOCK_MARK, one fragment per FXAA_BLOCK x FXAA_BLOCK block of pixels,
// marks the blocks holding an edge pixel; the filter is then drawn as one point of that
// size per marked block (passes/fxaa_blocks.vert), so only those blocks pay for the
// search (llvmpipe shades every branch of a fragment shader for its whole 4x4 block of
// pixels, and a fullscreen mark paid per pixel what this pays per block). The filter
// leaves a block's other pixels as they were (it writes their own bytes back). The resampling
// across the edge mixes the pixel with its neighbour in linear light (sRGB decoded),
// not in the encoded values, as the supersampled pixel integral does.
#include "post/tonemap.glsl"

// IEC 61966-2-1 sRGB transfer function (encoded -> linear): srgb_encode's inverse.
vec3 srgb_decode(vec3 c) {
    vec3 lo = c / 12.92;
    vec3 hi = pow((c + 0.055) / 1.055, vec3(2.4));
    return mix(lo, hi, step(vec3(0.04045), c));
}

uniform sampler2D u_display;    // RGBA8, sRGB-encoded, LINEAR filtered, clamped

out vec4 frag_color;

#ifndef FXAA_EDGE_THRESHOLD
#define FXAA_EDGE_THRESHOLD 0.125        // contrast, relative to the brightest, that is an edge
#endif
#ifndef FXAA_EDGE_THRESHOLD_MIN
#define FXAA_EDGE_THRESHOLD_MIN 0.0312   // and absolute: darker contrasts are left alone
#endif
#ifndef FXAA_SUBPIX
#define FXAA_SUBPIX 0.75                 // strength of the sub-pixel blend
#endif
const float EDGE_THRESHOLD = FXAA_EDGE_THRESHOLD;
const float EDGE_THRESHOLD_MIN = FXAA_EDGE_THRESHOLD_MIN;
const float SUBPIX = FXAA_SUBPIX;
const int STEPS = 12;

// the search's step along the edge at step i, in pixels (FXAA 3.11's quality preset 12)
float search_step(int i) {
    return i < 5 ? 1.0 : i == 5 ? 1.5 : i < 10 ? 2.0 : i == 10 ? 4.0 : 8.0;
}

float luma(vec4 c) {
    return dot(c.rgb, vec3(0.299, 0.587, 0.114));
}

ivec2 g_px;
ivec2 g_last;

float luma_at(int dx, int dy) {
    return luma(texelFetch(u_display, clamp(g_px + ivec2(dx, dy), ivec2(0), g_last), 0));
}

#ifdef FXAA_BLOCK_MARK
// A block is marked where any of its pixels' 4-neighbourhood contrast passes the edge
// test of the filter below (the same lumas, the same test), by a margin of 1e-6 that
// covers any rounding a compiler may do otherwise here: marking more blocks than needed
// changes no pixel (the filter decides each pixel itself), marking fewer would.
const int B = FXAA_BLOCK;
const int SIDE = B + 2;  // the block and its ring of neighbours

void main() {
    g_last = textureSize(u_display, 0) - 1;
    g_px = ivec2(gl_FragCoord.xy) * B - 1;  // the ring's lower-left texel
    float l[SIDE * SIDE];
    for (int j = 0; j < SIDE; ++j) {
        for (int i = 0; i < SIDE; ++i) {
            bool corner = (i == 0 || i == SIDE - 1) && (j == 0 || j == SIDE - 1);
            l[j * SIDE + i] = corner ? 0.0 : luma_at(i, j);
        }
    }
    bool marked = false;
    for (int j = 1; j <= B; ++j) {
        for (int i = 1; i <= B; ++i) {
            float m = l[j * SIDE + i];
            float n = l[(j + 1) * SIDE + i], s = l[(j - 1) * SIDE + i];
            float e = l[j * SIDE + i + 1], w = l[j * SIDE + i - 1];
            float lo = min(m, min(min(n, s), min(e, w)));
            float hi = max(m, max(max(n, s), max(e, w)));
            marked = marked || hi - lo >= max(EDGE_THRESHOLD_MIN, hi * EDGE_THRESHOLD) - 1e-6;
        }
    }
    frag_color = vec4(marked ? 1.0 : 0.0);
}
#else
void main() {
    vec2 size = vec2(textureSize(u_display, 0));
    vec2 texel = 1.0 / size;
    g_px = ivec2(gl_FragCoord.xy);
    g_last = ivec2(size) - 1;
    vec4 centre = texelFetch(u_display, g_px, 0);
    float m = luma(centre);
    float n = luma_at(0, 1), s = luma_at(0, -1), e = luma_at(1, 0), w = luma_at(-1, 0);
    float lo = min(m, min(min(n, s), min(e, w)));
    float hi = max(m, max(max(n, s), max(e, w)));
    float range = hi - lo;
    bool edge = range >= max(EDGE_THRESHOLD_MIN, hi * EDGE_THRESHOLD);
    if (!edge) {
        frag_color = centre;
        return;
    }
    float nw = luma_at(-1, 1), ne = luma_at(1, 1), sw = luma_at(-1, -1), se = luma_at(1, -1);
    // second differences across y (a horizontal edge) and across x (a vertical one)
    float across_y = abs(nw - 2.0 * w + sw) + 2.0 * abs(n - 2.0 * m + s) + abs(ne - 2.0 * e + se);
    float across_x = abs(nw - 2.0 * n + ne) + 2.0 * abs(w - 2.0 * m + e) + abs(sw - 2.0 * s + se);
    bool horizontal = across_y >= across_x;
    // the two neighbours across the edge, and the side with the steeper step
    float l_neg = horizontal ? s : w;
    float l_pos = horizontal ? n : e;
    float g_neg = abs(l_neg - m), g_pos = abs(l_pos - m);
    float step_len = horizontal ? texel.y : texel.x;
    float local;
    if (g_neg >= g_pos) {
        step_len = -step_len;
        local = 0.5 * (l_neg + m);
    } else {
        local = 0.5 * (l_pos + m);
    }
    float gradient = 0.25 * max(g_neg, g_pos);
    // walk along the edge, on the boundary between the pixel and its steeper neighbour
    vec2 uv = (vec2(g_px) + 0.5) * texel;
    vec2 on_edge = uv + (horizontal ? vec2(0.0, 0.5 * step_len) : vec2(0.5 * step_len, 0.0));
    vec2 along = horizontal ? vec2(texel.x, 0.0) : vec2(0.0, texel.y);
    vec2 uv1 = on_edge - along, uv2 = on_edge + along;
    float e1 = luma(texture(u_display, uv1)) - local;
    float e2 = luma(texture(u_display, uv2)) - local;
    bool done1 = abs(e1) >= gradient, done2 = abs(e2) >= gradient;
    for (int i = 1; i < STEPS && !(done1 && done2); ++i) {
        if (!done1) {
            uv1 -= along * search_step(i);
            e1 = luma(texture(u_display, uv1)) - local;
            done1 = abs(e1) >= gradient;
        }
        if (!done2) {
            uv2 += along * search_step(i);
            e2 = luma(texture(u_display, uv2)) - local;
            done2 = abs(e2) >= gradient;
        }
    }
    float d1 = horizontal ? uv.x - uv1.x : uv.y - uv1.y;
    float d2 = horizontal ? uv2.x - uv.x : uv2.y - uv.y;
    bool nearer1 = d1 < d2;
    // the edge reaches across this pixel by 0.5 at the span's middle, 0 at its ends
    float offset = 0.5 - min(d1, d2) / (d1 + d2);
    // only where the nearer end's luma lies on the other side of the local mean from m
    bool valid = ((nearer1 ? e1 : e2) < 0.0) != (m < local);
    offset = valid ? offset : 0.0;
    // sub-pixel aliasing: how far m stands out of its 3x3 neighbourhood's low-pass
    float low = (2.0 * (n + s + e + w) + (nw + ne + sw + se)) / 12.0;
    float sub = clamp(abs(low - m) / range, 0.0, 1.0);
    sub = (-2.0 * sub + 3.0) * sub * sub;
    offset = max(offset, sub * sub * SUBPIX);
    // the pixel across the edge, mixed in linear light by the offset, premultiplied by
    // alpha and divided again: a transparent frame's straight colours are not darkened by
    // the empty pixels' black (with alpha 1 everywhere this is the plain mix, exactly)
    ivec2 across = horizontal ? ivec2(0, step_len > 0.0 ? 1 : -1) : ivec2(step_len > 0.0 ? 1 : -1, 0);
    vec4 other = texelFetch(u_display, clamp(g_px + across, ivec2(0), g_last), 0);
    float alpha = mix(centre.a, other.a, offset);
    vec3 rgb = mix(srgb_decode(centre.rgb) * centre.a, srgb_decode(other.rgb) * other.a, offset);
    rgb = alpha > 0.0 ? rgb / alpha : vec3(0.0);
    frag_color = vec4(srgb_encode(rgb), alpha);
}
#endif
