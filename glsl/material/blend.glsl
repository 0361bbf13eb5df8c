// Blending materials by their parameters (RTR4 sec. 9.13). Twin: app/reference/blend.py.
// A mask paints one material onto another in the G-buffer pass: the BRDF inputs are
// mixed, never the shaded colours, so the result is again one material that the lighting
// pass shades once.
#ifndef PBS_BLEND_GLSL
#define PBS_BLEND_GLSL

// The material parameters one layer contributes to a G-buffer texel.
struct Layer {
    vec3 base_color;             // linear
    float metallic;
    float perceptual_roughness;  // r; alpha = r^2
    float f0;                    // dielectric F0
    float anisotropy;
    vec3 normal;                 // unit, tangent space (+z = the surface normal)
};

// Weight of the top layer: a smoothstep ramp `softness` wide centred on `threshold`
// (0 below, 1 above; a hard step at softness = 0, where smoothstep is undefined).
float blend_weight(float mask, float threshold, float softness) {
    if (softness <= 0.0) return mask >= threshold ? 1.0 : 0.0;
    float x = clamp((mask - (threshold - 0.5 * softness)) / softness, 0.0, 1.0);
    return x * x * (3.0 - 2.0 * x);
}

// RTR4 sec. 9.13: parameters mix linearly (base colour in linear RGB; roughness in the
// perceptual r that artists paint, as Unreal's and Filament's layered materials do);
// normals mix as vectors and are renormalised. Tangent-space normals of both layers have
// z > 0, so the mix never vanishes.
Layer blend_layers(Layer a, Layer b, float w) {
    return Layer(mix(a.base_color, b.base_color, w),
                 mix(a.metallic, b.metallic, w),
                 mix(a.perceptual_roughness, b.perceptual_roughness, w),
                 mix(a.f0, b.f0, w),
                 mix(a.anisotropy, b.anisotropy, w),
                 normalize(mix(a.normal, b.normal, w)));
}

#endif
