// Exposure, tone mapping and the sRGB encoding. Twin: app/reference/tonemap.py.
#ifndef PBS_TONEMAP_GLSL
#define PBS_TONEMAP_GLSL

// Khronos PBR Neutral (2024): keeps base colours faithful up to a knee, then
// compresses highlights towards white while desaturating.
vec3 tonemap_khronos_neutral(vec3 c) {
    const float start = 0.8 - 0.04;
    const float desaturation = 0.15;
    float x = min(c.r, min(c.g, c.b));
    float offset = x < 0.08 ? x - 6.25 * x * x : 0.04;
    c -= offset;
    float peak = max(c.r, max(c.g, c.b));
    if (peak < start) return c;
    float d = 1.0 - start;
    float new_peak = 1.0 - d * d / (peak + d - start);
    c *= new_peak / peak;
    float g = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0);
    return mix(c, vec3(new_peak), g);
}

// Narkowicz 2015, "ACES Filmic Tone Mapping Curve" (fit of the ACES RRT+ODT).
vec3 tonemap_aces_narkowicz(vec3 x) {
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

// Reinhard et al. 2002, "Photographic Tone Reproduction", L / (1 + L) per channel.
vec3 tonemap_reinhard(vec3 x) {
    return x / (1.0 + x);
}

// IEC 61966-2-1 sRGB transfer function (linear -> encoded).
vec3 srgb_encode(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    vec3 lo = 12.92 * c;
    vec3 hi = 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055;
    return mix(lo, hi, step(vec3(0.0031308), c));
}

#ifdef TONEMAP
// Every tone map is white (or clamped) long before this; without the cap, radiance x 2^EV
// can overflow float32 inside a tone map (ACES squares its input: NaN past ~1.2e19).
const float MAX_EXPOSED = 1.0e9;

// Exposed radiance (linear, times 2^EV) -> tone-mapped linear display values, by the
// program's TONEMAP define (the scene's render.tonemap); the post pass and the
// comparison's difference view (passes/compare.frag) share it.
vec3 tonemap_selected(vec3 c) {
    c = min(c, MAX_EXPOSED);
#if TONEMAP == TONEMAP_NEUTRAL
    c = tonemap_khronos_neutral(c);
#elif TONEMAP == TONEMAP_ACES
    c = tonemap_aces_narkowicz(c);
#elif TONEMAP == TONEMAP_REINHARD
    c = tonemap_reinhard(c);
#endif
    return c;
}
#endif

#endif
