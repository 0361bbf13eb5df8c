// Glass pass of the shadow maps (app/render/shadows.py _run_glass): a transmissive part's
// surface facing the light, depth-tested against the opaque depth of the map (not writing
// it), multiplies the glass target's rgb by its transmittance (blend ZERO, SRC_COLOR) and
// keeps the nearest glass window depth in alpha (blend equation MIN). The transmittance is
// the transmission pass's weight at normal incidence, once per body (docs/shadows.md,
// "Glass"; float64 twin app/reference/glass_shadows.py glass_transmittance):
//   T = transmission (1 - metallic) (1 - F0) base_color exp(-sigma d),
//   sigma = -ln(attenuation_color) / attenuation_distance, d = thickness x scale.
#include "brdf/transmission.glsl"

uniform vec4 u_glass;               // transmission, metallic, F0, thickness in metres
uniform vec4 u_glass_attenuation;   // attenuation colour, attenuation distance (0: none)
uniform vec3 u_glass_base_color;

out vec4 frag_color;

vec3 glass_transmittance(vec3 base_color, float transmission, float metallic, float f0,
                         float d, vec3 attenuation_color, float attenuation_distance) {
    return transmission * (1.0 - metallic) * (1.0 - f0) * base_color
        * beer_lambert(attenuation_color, attenuation_distance, d);
}

void main() {
    vec3 t = glass_transmittance(u_glass_base_color, u_glass.x, u_glass.y, u_glass.z, u_glass.w,
                                 u_glass_attenuation.rgb, u_glass_attenuation.w);
    frag_color = vec4(t, gl_FragCoord.z);
}
