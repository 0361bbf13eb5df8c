// Cube-map texel directions (the OpenGL 4.6 spec's table 8.19, "Selection of cube map
// images", inverted). Twin: app/reference/environment.py cube_direction.
#ifndef PBS_ENV_CUBE_GLSL
#define PBS_ENV_CUBE_GLSL

// The (unnormalised) direction of face `face` (0..5 = +X, -X, +Y, -Y, +Z, -Z) at texture
// coordinates st in [0, 1]^2, the inverse of GL's s = (sc / |ma| + 1) / 2,
// t = (tc / |ma| + 1) / 2 face selection.
vec3 cube_direction(int face, vec2 st) {
    float sc = 2.0 * st.x - 1.0, tc = 2.0 * st.y - 1.0;
    if (face == 0) return vec3(1.0, -tc, -sc);
    if (face == 1) return vec3(-1.0, -tc, sc);
    if (face == 2) return vec3(sc, 1.0, tc);
    if (face == 3) return vec3(sc, -1.0, -tc);
    if (face == 4) return vec3(sc, -tc, 1.0);
    return vec3(-sc, -tc, -1.0);
}

#endif
