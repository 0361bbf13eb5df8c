// Glass pass of the shadow maps (app/render/shadows.py _run_glass): a transmissive part's
// surface facing the light, depth-tested against the opaque depth of the map (not writing
// it), multiplies the glass target's rgb by its transmittance (blend ZERO, SRC_COLOR) and
// keeps the nearest glass window depth in alpha (blend equation MIN). The transmittance is
// the transmission pass's weight at normal incidence, once per body (docs/shadows.md,
// "Glass"; float64 twin app/reference/glass_shadows.py glass_transmittance):
//   T = transmission (1 - metallic) (1 - F0) base_color exp(-sigma d),
//   sigma = -ln(attenuation_color) / attenuation_distance, d = thickness x scale.
// With GLASS_MAPS (a mesh whose layer 0 has a base colour, transmission or thickness map,
// or COLOR_0: app/render/shadows.py _TexturedGlassCaster) the vertex stage is
// passes/gbuffer.vert (u_view the identity, u_proj the light's matrix) and the three
// factors are those the transmission pass reads at the same UV: base_color times the base
// colour map's RGB and COLOR_0's, transmission times transmissionTexture's R, thickness
// times thicknessTexture's G (material/layers.glsl, the transmission_maps factor target).
#include "brdf/transmission.glsl"
// (after the unconditional include: the assembler includes a file once, where first named)
#if GLASS_MAPS
#include "material/layers.glsl"
#endif

uniform vec4 u_glass;               // transmission, metallic, F0, thickness in metres
uniform vec4 u_glass_attenuation;   // attenuation colour, attenuation distance (0: none)
uniform vec3 u_glass_base_color;

#if GLASS_MAPS
in vec2 v_uv;
#if VERTEX_COLOR
in vec4 v_color;
#endif
#if VERTEX_UV1
in vec2 v_uv1;
#endif
#endif

out vec4 frag_color;

vec3 glass_transmittance(vec3 base_color, float transmission, float metallic, float f0,
                         float d, vec3 attenuation_color, float attenuation_distance) {
    return transmission * (1.0 - metallic) * (1.0 - f0) * base_color
        * beer_lambert(attenuation_color, attenuation_distance, d);
}

void main() {
    vec3 base_color = u_glass_base_color;
    float transmission = u_glass.x;
    float thickness = u_glass.w;
#if GLASS_MAPS
#if VERTEX_COLOR
    vertex_color = v_color;
#endif
#if VERTEX_UV1
    vertex_uv1 = v_uv1;
#endif
#if (LAYER0_MAPS & MAP_BASE_COLOR) != 0
    base_color *= sample_layer_map(u_base_color_map0, v_uv, u_layer0.uv_scale, 0,
                                   MAP_INDEX_BASE_COLOR).rgb;
#endif
    base_color *= vertex_color.rgb;
#if TRANSMISSION_MAPS
    vec4 factors = sample_transmission_maps(v_uv);   // R: transmission, G: thickness
    transmission *= factors.r;
    thickness *= factors.g;
#endif
#endif
    vec3 t = glass_transmittance(base_color, transmission, u_glass.y, u_glass.z, thickness,
                                 u_glass_attenuation.rgb, u_glass_attenuation.w);
    frag_color = vec4(t, gl_FragCoord.z);
}
