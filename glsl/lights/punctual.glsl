// Punctual lights: direction to the light and c_light at the shaded point.
// Twin: app/reference/punctual.py.
#ifndef PBS_PUNCTUAL_GLSL
#define PBS_PUNCTUAL_GLSL

// The light types LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT (and the area lights'
// LIGHT_RECT, ...) are generated from app/common/lights.py LightType at the top of every
// program.

// AREA_LIGHTS: 1 where the frame has an area light (lights/area.glsl), else absent.
#ifndef AREA_LIGHTS
#define AREA_LIGHTS 0
#endif

// Distance floor for the inverse-square law (RTR4 eq. 5.11: a light is never closer
// than about 1 cm), so a light touching a surface stays finite.
const float LIGHT_MIN_DISTANCE = 0.01;

// SPOT_LIGHTS 0: the frame has no spot light (app/render/inputs.py LightInput), so the cone
// is compiled out of local_light_at. A SIMD rasteriser such as llvmpipe evaluates an `if`'s
// body for every light, masked, so a point light would pay for the cone it never applies
// (docs/performance.md, "Peers", measures it). Every pass that does not say assumes spots.
#ifndef SPOT_LIGHTS
#define SPOT_LIGHTS 1
#endif

struct PunctualLight {
    int type;
    vec3 position;        // world space (point, spot)
    vec3 direction;       // unit, the way the light travels (directional, spot)
    vec3 color;           // linear RGB c_light at 1 m (point, spot) or everywhere (directional)
    float range;          // point, spot: the window reaches exactly 0 here
    float cos_outer;      // spot: cosine of the outer cone half-angle
    float cos_inner;      // spot: cosine of the inner cone half-angle
};

// Karis 2013, "Real Shading in Unreal Engine 4"; RTR4 eq. 5.14:
//   f_win(r) = ((1 - (r/r_max)^4)+)^2, smooth and exactly 0 at r = r_max.
float window_falloff(float dist2, float range) {
    float x = dist2 / (range * range);
    float t = clamp(1.0 - x * x, 0.0, 1.0);
    return t * t;
}

// RTR4 eq. 5.18-5.19 (Frostbite): t = clamp((cos theta - cos outer)/(cos inner - cos outer)), t^2.
float spot_cone(float cos_theta, float cos_outer, float cos_inner) {
    float t = clamp((cos_theta - cos_outer) / max(cos_inner - cos_outer, 1e-4), 0.0, 1.0);
    return t * t;
}

// light_at (below) of a point or spot light. The loops that visit only local lights (a
// tile's list) call it directly: without light_at's test for a directional light, whose
// early return a SIMD rasteriser runs masked for every light (docs/performance.md,
// "The light loop").
vec3 local_light_at(PunctualLight L, vec3 p, out vec3 l) {
    vec3 d = L.position - p;
    float dist2 = dot(d, d);
    l = d * inversesqrt(max(dist2, 1e-20));
    float atten = window_falloff(dist2, L.range)
                / max(dist2, LIGHT_MIN_DISTANCE * LIGHT_MIN_DISTANCE);
#if SPOT_LIGHTS
    if (L.type == LIGHT_SPOT) atten *= spot_cone(dot(-l, L.direction), L.cos_outer, L.cos_inner);
#endif
    return L.color * atten;
}

// Returns c_light arriving at p (RTR4 sec. 9.4's c_light, already attenuated) and
// writes the unit direction from p towards the light into l.
vec3 light_at(PunctualLight L, vec3 p, out vec3 l) {
    if (L.type == LIGHT_DIRECTIONAL) {
        l = -L.direction;
        return L.color;
    }
    return local_light_at(L, p, l);
}

// Light i of a light texture (app/common/lights.py pack_lights): 3 RGBA32F texels per
// light, one light per row. The type is implied by the numbers: range < 0 marks a
// directional light, cos_outer < -1 a point light (no cone).
// The same three texels however they reach the shader: a texture here, a uniform array or
// block in the bench's limit pass (glsl/passes/limit.frag).
PunctualLight unpack_light(vec4 t0, vec4 t1, vec4 t2) {
    int type = t1.w < 0.0 ? LIGHT_DIRECTIONAL : (t2.w < -1.0 ? LIGHT_POINT : LIGHT_SPOT);
#if AREA_LIGHTS
    // an area light's code (app/common/lights.py AREA_CODE_BASE - k): below -2.5
    if (t2.w < -2.5) type = LIGHT_RECT + int(-t2.w - 2.5);
#endif
    return PunctualLight(type, t0.xyz, t1.xyz, t2.rgb, t1.w, t2.w, t0.w);
}

PunctualLight fetch_light(sampler2D lights, int i) {
    return unpack_light(texelFetch(lights, ivec2(0, i), 0), texelFetch(lights, ivec2(1, i), 0),
                        texelFetch(lights, ivec2(2, i), 0));
}

#endif
