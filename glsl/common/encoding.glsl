// Octahedral unit-vector encoding for the G-buffer normal.
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

#endif
