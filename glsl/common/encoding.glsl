// Octahedral unit-vector encoding for the G-buffer normal, and the map of signed values
// into a unorm target.
// Cigolle et al. 2014, "A Survey of Efficient Representations for Independent Unit Vectors".
// Twin: app/reference/encoding.py.
#ifndef PBS_ENCODING_GLSL
#define PBS_ENCODING_GLSL

// sign() returns 0 at 0, which would fold the seam onto the axis; use +1 there.
vec2 sign_not_zero(vec2 v) {
    return vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0);
}

// Unit vector -> point in [-1, 1]^2.
vec2 oct_encode(vec3 n) {
    vec2 p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    return n.z >= 0.0 ? p : (1.0 - abs(p.yx)) * sign_not_zero(p);
}

// Point in [-1, 1]^2 -> unit vector.
vec3 oct_decode(vec2 e) {
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    if (n.z < 0.0) n.xy = (1.0 - abs(n.yx)) * sign_not_zero(n.xy);
    return normalize(n);
}

// [-1, 1] -> [0, 1]: a signed G-buffer value (octahedral coordinate, anisotropy) as a
// 16-bit unorm target stores it. The map puts snorm16's grid into the unorm codes: the code
// k = round(u * 65535) decodes to (k - 32767) / 32767, a uniform grid of step 1/32767 on
// which -1, 0 and 1 are exact (code 65535 is unused), so a normal along an axis (a floor,
// a box's face) and anisotropy 0 survive the store exactly (Cigolle et al. 2014 quantise the
// octahedral square on such a grid). The target clamps to [0, 1] on store.
vec2 snorm_to_unorm(vec2 x) { return (x * 32767.0 + 32767.0) / 65535.0; }
float snorm_to_unorm(float x) { return (x * 32767.0 + 32767.0) / 65535.0; }

// [0, 1] -> [-1, 1]: the inverse, as the decode applies it.
vec2 unorm_to_snorm(vec2 u) { return (u * 65535.0 - 32767.0) / 32767.0; }
float unorm_to_snorm(float u) { return (u * 65535.0 - 32767.0) / 32767.0; }

// x, or fallback where x is NaN or +-Inf (the exponent-bits test of brdf/material.glsl's
// is_finite). A float target carries NaN to the decode, whose sanitize_value replaces it
// with the field's fallback; a unorm target cannot store NaN (the GL converts it to some
// code in [0, 1]), so the G-buffer pass applies the same fallback before a unorm store.
float finite_or(float x, float fallback) {
    return (floatBitsToUint(x) & 0x7F800000u) != 0x7F800000u ? x : fallback;
}

#endif
