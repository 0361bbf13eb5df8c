// Gathering a fragment's material in the G-buffer pass (and the bench's forward pass):
// layer constants times their texture maps, an optional second layer painted on by a
// mask (RTR4 sec. 9.13), tangent-space normal mapping, and optional screen-space
// geometric specular antialiasing. Which maps a layer samples is a compile-time bitmask
// (LAYER0_MAPS, LAYER1_MAPS), so the compiler drops every lookup a material lacks.
#ifndef PBS_LAYERS_GLSL
#define PBS_LAYERS_GLSL

#include "geometry/analytic.glsl"
#include "material/blend.glsl"
#include "material/filtering.glsl"
#include "material/normal_mapping.glsl"

// MAP_<KEY>: each map's bit in LAYER<i>_MAPS, MAP_INDEX_<KEY> its index (bit = 1 << index),
// MAP_COUNT: generated from app/common/extension_maps.py (core, extension, shared-UV maps).
#include "generated/map_bits.glsl"

#ifndef LAYER0_MAPS
#define LAYER0_MAPS 0
#endif
#ifndef LAYER1_MAPS
#define LAYER1_MAPS 0
#endif
#ifndef BLEND
#define BLEND 0
#endif
#ifndef SPECULAR_AA
#define SPECULAR_AA 0
#endif
#ifndef ALPHA_MASK
#define ALPHA_MASK 0
#endif
#ifndef VERTEX_COLOR
#define VERTEX_COLOR 0
#endif
// render.normal_filter = "lean": a layer's normal map comes with the covariance of its slopes
// (app/textures/lean.py), which becomes anisotropic roughness and a tangent per pixel. The
// map is made from the normal map and read through its UVs and transform.
#define LEAN_FILTERING (((LAYER0_MAPS | LAYER1_MAPS) & MAP_SLOPE_COVARIANCE) != 0)
// Layer 0 turns its tangent about the normal by a constant angle (glTF
// KHR_materials_anisotropy's anisotropyRotation; the scene key anisotropy_rotation).
#ifndef ANISOTROPY_ROTATION
#define ANISOTROPY_ROTATION 0
#endif
// Layer 0's maps (MAP_* bits) read through a KHR_texture_transform matrix
// (u_uv_transform0[index]), and those of them that read TEXCOORD_1 instead of TEXCOORD_0.
#ifndef UV_TRANSFORM_MAPS0
#define UV_TRANSFORM_MAPS0 0
#endif
#ifndef UV_SET1_MAPS0
#define UV_SET1_MAPS0 0
#endif
struct LayerConstants {
    vec3 base_color;
    float metallic;
    float roughness;
    float f0;
    float anisotropy;
    vec2 uv_scale;
};

uniform LayerConstants u_layer0;
uniform float u_material_id0;   // rows of the lighting pass's material table
uniform float u_material_id1;
uniform sampler2D u_base_color_map0;
uniform sampler2D u_metallic_map0;
uniform sampler2D u_anisotropy_map0;
uniform sampler2D u_normal_roughness_map0;
uniform sampler2D u_f0_map0;
uniform sampler2D u_select_map0;
uniform sampler2D u_coat_normal_map0;
#if LEAN_FILTERING
uniform sampler2D u_slope_covariance_map0;
uniform sampler2D u_slope_covariance_map1;
#endif
#if BLEND
uniform LayerConstants u_layer1;
uniform sampler2D u_base_color_map1;
uniform sampler2D u_metallic_map1;
uniform sampler2D u_anisotropy_map1;
uniform sampler2D u_normal_roughness_map1;
uniform sampler2D u_blend_mask;
uniform vec2 u_blend;           // threshold, softness
#endif
#if GBUFFER_EMISSION
uniform vec3 u_emissive0;            // emitted radiance (glTF emissiveFactor x strength)
uniform float u_occlusion_strength0;
uniform sampler2D u_emissive_map0;
uniform sampler2D u_occlusion_map0;
#endif
#if ANISOTROPY_ROTATION
uniform vec2 u_anisotropy_rotation0;  // (cos, sin) of the angle, from float64 on the CPU
#endif
#if (LAYER0_MAPS & MAP_ANISOTROPY_DIRECTION) != 0
uniform sampler2D u_anisotropy_direction_map0;
#endif
#if ALPHA_MASK || ALPHA_BLEND
uniform float u_alpha0;              // glTF baseColorFactor's A
#endif
#if ALPHA_MASK
uniform float u_alpha_cutoff0;
#endif
#if UV_TRANSFORM_MAPS0 != 0
uniform mat3 u_uv_transform0[MAP_COUNT];  // uv' = M uv per map index, before uv_scale
#endif
// glTF COLOR_0 and TEXCOORD_1 of the fragment, set by the pass's main() from its inputs
// (identity and unused where the mesh has none).
vec4 vertex_color = vec4(1.0);
vec2 vertex_uv1 = vec2(0.0);
#if SPECULAR_AA
uniform vec2 u_specular_aa;     // sigma^2 of the pixel filter, kappa (the largest alpha^2 added)
#endif

// A material map at uv times the layer's UV scale. An analytic surface's UVs are computed
// per pixel and jump by a whole turn at the sphere's longitude seam, so the implicit
// derivatives would pick the smallest mip in a line along it: its own continuous
// derivatives (geometry/analytic.glsl) are used instead.
vec4 sample_map(sampler2D map, vec2 uv, vec2 scale) {
#if ANALYTIC
    return textureGrad(map, uv * scale, analytic_uv_ddx * scale, analytic_uv_ddy * scale);
#else
    return texture(map, uv * scale);
#endif
}

// Map `index` of layer `layer` at uv: layer 0's maps named in UV_TRANSFORM_MAPS0 read
// their UV set (UV_SET1_MAPS0: TEXCOORD_1) through their KHR_texture_transform matrix,
// then the UV scale; an analytic surface's derivatives go through the matrix's linear part
// (the chain rule). Every other map is sample_map's, unchanged.
vec4 sample_layer_map(sampler2D map, vec2 uv, vec2 scale, int layer, int index) {
#if UV_TRANSFORM_MAPS0 != 0
    if (layer == 0 && (UV_TRANSFORM_MAPS0 & (1 << index)) != 0) {
        mat3 m = u_uv_transform0[index];
        vec2 src = (UV_SET1_MAPS0 & (1 << index)) != 0 ? vertex_uv1 : uv;
        vec2 t = (m * vec3(src, 1.0)).xy;
#if ANALYTIC
        mat2 j = mat2(m);
        return textureGrad(map, t * scale, (j * analytic_uv_ddx) * scale,
                           (j * analytic_uv_ddy) * scale);
#else
        return texture(map, t * scale);
#endif
    }
#endif
    return sample_map(map, uv, scale);
}

// One layer's parameters at texture coordinate uv. `maps` is a constant, so after
// inlining every branch below is resolved at compile time.
Layer read_layer(LayerConstants c, int layer, int maps, vec2 uv, sampler2D base_color_map,
                 sampler2D metallic_map, sampler2D anisotropy_map,
                 sampler2D normal_roughness_map, sampler2D f0_map) {
    Layer l = Layer(c.base_color, c.metallic, c.roughness, c.f0, c.anisotropy,
                    vec3(0.0, 0.0, 1.0));
    if ((maps & MAP_BASE_COLOR) != 0)
        l.base_color *= sample_layer_map(base_color_map, uv, c.uv_scale, layer,
                                         MAP_INDEX_BASE_COLOR).rgb;
    if ((maps & MAP_METALLIC) != 0)
        l.metallic *= sample_layer_map(metallic_map, uv, c.uv_scale, layer, MAP_INDEX_METALLIC).r;
    if ((maps & MAP_ANISOTROPY) != 0)
        l.anisotropy *= sample_layer_map(anisotropy_map, uv, c.uv_scale, layer,
                                         MAP_INDEX_ANISOTROPY).r;
    if ((maps & MAP_F0) != 0) l.f0 *= sample_layer_map(f0_map, uv, c.uv_scale, layer, MAP_INDEX_F0).r;
    if ((maps & MAP_NORMAL_ROUGHNESS) != 0) {
        vec4 nr = sample_layer_map(normal_roughness_map, uv, c.uv_scale, layer,
                                   MAP_INDEX_NORMAL_ROUGHNESS);
        l.normal = tangent_space_normal(nr.xyz);
        l.perceptual_roughness = nr.a;
    }
    return l;
}

// A fragment's material: the mixed layer, its shading frame in world space and its row.
struct MaterialSample {
    Layer layer;
    vec3 n;             // unit shading normal (normal-mapped), facing the viewer's side
    vec3 nc;            // unit clear-coat normal: the coat's own normal map, else the
                        // interpolated vertex normal (never the base's normal map)
    vec3 t;             // tangent along +u (not yet orthogonal to n; the lighting pass does it)
    float material_id;
};

// `normal` and `tangent` (xyz along +u, w = handedness) are the interpolated vertex frame
// in world space; back faces of two-sided surfaces reverse the shading normals towards the
// viewer (glTF 2.0 material.doubleSided: "The back-face must have its normals reversed").
// The normal maps and the anisotropy direction are applied in the front face's frame and
// the mapped normals then reversed whole: reversing only the geometric normal first would
// also reverse the frame's bitangent cross(ng, t) but not t, so a back face would show the
// map's tilt along t mirrored and its anisotropy turned the other way.
MaterialSample sample_material(vec3 normal, vec4 tangent, vec2 uv, bool front_facing) {
    Layer l = read_layer(u_layer0, 0, LAYER0_MAPS, uv, u_base_color_map0, u_metallic_map0,
                         u_anisotropy_map0, u_normal_roughness_map0, u_f0_map0);
#if VERTEX_COLOR
    l.base_color *= vertex_color.rgb;   // glTF COLOR_0 multiplies the base colour
#endif
    float id = u_material_id0;
#if LEAN_FILTERING
    // Olano & Baker 2010: the covariance of the slopes under the pixel's texels (0 where a
    // layer has no normal map); a blend mixes its layers' covariances as it mixes roughness.
    vec3 sigma = vec3(0.0);
#if (LAYER0_MAPS & MAP_SLOPE_COVARIANCE) != 0
    sigma = sample_layer_map(u_slope_covariance_map0, uv, u_layer0.uv_scale, 0,
                             MAP_INDEX_NORMAL_ROUGHNESS).rgb;
#endif
#endif
#if BLEND
    // Only a baked blend has an F0 map, and it has no second layer: layer 1 never samples
    // one, so layer 0's sampler fills the slot.
    Layer top = read_layer(u_layer1, 1, LAYER1_MAPS, uv, u_base_color_map1, u_metallic_map1,
                           u_anisotropy_map1, u_normal_roughness_map1, u_f0_map0);
    float w = blend_weight(sample_map(u_blend_mask, uv, u_layer0.uv_scale).r, u_blend.x,
                           u_blend.y);
    l = blend_layers(l, top, w);
#if LEAN_FILTERING && (LAYER1_MAPS & MAP_SLOPE_COVARIANCE) != 0
    sigma = mix(sigma, sample_map(u_slope_covariance_map1, uv, u_layer1.uv_scale).rgb, w);
#elif LEAN_FILTERING
    sigma *= 1.0 - w;
#endif
    // The optional models' numbers (eta, k, ...) cannot be mixed per pixel: the layer
    // that dominates gives the row.
    if (w >= 0.5) id = u_material_id1;
#endif
#if (LAYER0_MAPS & MAP_SELECT) != 0
    if (sample_layer_map(u_select_map0, uv, u_layer0.uv_scale, 0, MAP_INDEX_SELECT).r >= 0.5)
        id = u_material_id1;
#endif
    float side = front_facing ? 1.0 : -1.0;
    vec3 ng = normalize(normal);
    float t_len = length(tangent.xyz);
    vec3 t = t_len > 0.0 ? tangent.xyz / t_len : vec3(0.0);
    vec3 n = ng;
#if ((LAYER0_MAPS | LAYER1_MAPS) & MAP_NORMAL_ROUGHNESS) != 0
    n = perturb_normal(ng, t, tangent.w, l.normal);
#endif
    // glTF KHR_materials_clearcoat: "If clearcoatNormalTexture is not given, no normal
    // mapping is applied to the clear coat layer, even if normal mapping is applied to the
    // base material"; with it, the coat's map on the same tangent frame as the base's.
    vec3 nc = ng;
#if (LAYER0_MAPS & MAP_COAT_NORMAL) != 0
    vec4 coat = sample_layer_map(u_coat_normal_map0, uv, u_layer0.uv_scale, 0,
                                 MAP_INDEX_COAT_NORMAL);
    nc = perturb_normal(ng, t, tangent.w, tangent_space_normal(coat.xyz));
#endif
    // glTF KHR_materials_anisotropy (RTR4 sec. 9.8): the direction of anisotropy is the
    // direction map's texel (else +t), turned counter-clockwise from t towards b by the
    // rotation, in the geometric frame that normal mapping uses. The G-buffer stores the
    // turned tangent, so the lighting pass reads it as any other.
#if ANISOTROPY_ROTATION || (LAYER0_MAPS & MAP_ANISOTROPY_DIRECTION) != 0 || LEAN_FILTERING
    vec2 dir = vec2(1.0, 0.0);
#if (LAYER0_MAPS & MAP_ANISOTROPY_DIRECTION) != 0
    dir = anisotropy_direction(sample_layer_map(u_anisotropy_direction_map0, uv,
                                                u_layer0.uv_scale, 0,
                                                MAP_INDEX_ANISOTROPY_DIRECTION).rg);
#endif
#if ANISOTROPY_ROTATION
    vec2 cs = u_anisotropy_rotation0;
    dir = vec2(cs.x * dir.x - cs.y * dir.y, cs.y * dir.x + cs.x * dir.y);
#endif
#if LEAN_FILTERING
    // The material's lobe widened by the covariance: anisotropic roughness along the
    // covariance's major axis (material/filtering.glsl; RTR4 sec. 9.8 and 9.13).
    vec4 lean = lean_anisotropic_roughness(l.perceptual_roughness, l.anisotropy, dir, sigma,
                                           LEAN_SPREAD);
    l.perceptual_roughness = lean.x;
    l.anisotropy = lean.y;
    dir = lean.zw;
#endif
    if (t_len > 0.0) t = rotate_tangent(ng, t, tangent.w, dir);
#endif
#if SPECULAR_AA
    // Tokuyoshi & Kaplanyan 2019: the normal's screen-space variation widens the NDF.
    l.perceptual_roughness = perceptual_roughness_specular_aa(
        l.perceptual_roughness, dFdx(n), dFdy(n), u_specular_aa.x, u_specular_aa.y);
#endif
    n *= side;
    nc *= side;
    return MaterialSample(l, n, nc, t_len > 0.0 ? t : n, id);
}

#if GBUFFER_EMISSION
// glTF 2.0 core material: emitted radiance (emissive times the sRGB emissive map) and the
// occlusion factor 1 + strength (occlusion - 1), layer 0's (a blend's top layer neither
// emits nor occludes). RT5 of the G-buffer.
vec4 sample_emission(vec2 uv) {
    vec3 e = u_emissive0;
    float ao = 1.0;
#if (LAYER0_MAPS & MAP_EMISSIVE) != 0
    e *= sample_layer_map(u_emissive_map0, uv, u_layer0.uv_scale, 0, MAP_INDEX_EMISSIVE).rgb;
#endif
#if (LAYER0_MAPS & MAP_OCCLUSION) != 0
    float occlusion = sample_layer_map(u_occlusion_map0, uv, u_layer0.uv_scale, 0,
                                       MAP_INDEX_OCCLUSION).r;
    ao = 1.0 + u_occlusion_strength0 * (occlusion - 1.0);
#endif
    return vec4(e, ao);
}
#endif

// The extension maps (app/common/extension_maps.py EXTENSION_MAPS), generated per factor
// target under its define: its maps' samplers and vec4 sample_<target>(uv), each map's
// texels in its slot, 1 where layer 0 has no such map. sample_layer_maps (RT6: the sheen
// or specular colour in RGB, the coat's strength or the sheen roughness in A),
// sample_coat_film_maps (RT8: the coat's roughness, the film's strength and thickness) and
// sample_transmission_maps (the transmission pass: glass's share and thickness); the
// lighting pass and the forward pass apply them with brdf/material.glsl's scale_by_<target>.
#include "generated/extension_sampling.glsl"

#if ALPHA_MASK || ALPHA_BLEND
// glTF 2.0 coverage: the layer's alpha times the base colour map's A and COLOR_0's A.
float coverage(vec2 uv) {
    float a = u_alpha0 * vertex_color.a;
#if (LAYER0_MAPS & MAP_BASE_COLOR) != 0
    a *= sample_layer_map(u_base_color_map0, uv, u_layer0.uv_scale, 0, MAP_INDEX_BASE_COLOR).a;
#endif
    return a;
}
#endif

#endif
