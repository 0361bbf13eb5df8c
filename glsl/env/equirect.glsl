// The equirectangular environment map's direction convention (docs/ibl.md).
// Twin: app/reference/environment.py.
#ifndef PBS_ENV_EQUIRECT_GLSL
#define PBS_ENV_EQUIRECT_GLSL

#include "common/constants.glsl"

// Texture coordinates of world direction d in a map turned `rotation` radians about +Y:
// u = 1/2 + atan2(d.x, -d.z) / (2 pi) (the centre column looks along -Z),
// v = acos(d.y) / pi (row 0, v = 0, is straight up). The map is uploaded row 0 first,
// so v is the texture's t directly.
// World direction d in the frame of a map turned `rotation` radians about +Y.
vec3 env_map_direction(vec3 d, float rotation) {
    float c = cos(rotation), s = sin(rotation);
    return vec3(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
}

vec2 equirect_uv(vec3 d, float rotation) {
    vec3 m = normalize(env_map_direction(d, rotation));
    return vec2(0.5 + atan(m.x, -m.z) * (0.5 * INV_PI),
                acos(clamp(m.y, -1.0, 1.0)) * INV_PI);
}

#endif
