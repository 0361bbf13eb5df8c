// Forward pass (the bench's baseline): each object's fragments loop over every light.
//   L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+          (RTR4 sec. 9.4)
// The same terms as glsl/passes/lighting.frag (surface_radiance of lights/shading.glsl),
// but the surface comes straight from the material uniforms and the interpolated vertex
// attributes instead of a G-buffer: no quantisation, no culling, and
// occluded fragments that reach the shader before their occluder are shaded too.
// With ALPHA_BLEND it is the renderer's pass for glTF alphaMode BLEND (app/render/blend.py):
// the fragment's full outgoing radiance (surface_radiance: the sum with shadows, the
// environment's light, emission, occlusion) with its coverage as alpha, composited
// "over" the lit HDR image by the fixed-function blend.
// With TRANSMISSION it is the transmission pass (app/render/transmission.py): the diffuse
// base weighted by (1 - transmission), plus the light of the opaque image behind the
// surface refracted through it and the punctual lights seen through it
// (brdf/transmission.glsl), written over the pixel.
#include "brdf/brdf.glsl"
#include "common/position.glsl"
#include "geometry/analytic.glsl"
#include "lights/shading.glsl"
#include "material/layers.glsl"
#if TRANSMISSION
#include "brdf/transmission.glsl"
#endif

in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
in float v_view_depth;
#if VERTEX_COLOR
in vec4 v_color;   // glTF COLOR_0 (passes/gbuffer.vert)
#endif
#if VERTEX_UV1
in vec2 v_uv1;     // glTF TEXCOORD_1
#endif

uniform sampler2D u_materials;  // RGBA32F, MATERIAL_TEXELS per material (app/common/material_fields.py)
// u_camera_pos, u_camera_to_world, u_tan_half_fov, u_image_size: geometry/analytic.glsl

#if TRANSMISSION
// The opaque HDR image (premultiplied RGBA) with its mip chain (app/render/transmission.py)
uniform sampler2D u_transmission_image;
uniform sampler2D u_transmission_depth;  // the G-buffer's RT2: view depth (0: nothing)
uniform mat4 u_view;   // passes/gbuffer.vert's (geometry/analytic.glsl: u_model, u_proj)
uniform float u_thickness_scale;   // |det(model)|^(1/3): object units to world units

// Fixed-point steps of the search for where the ray leaving a volume meets the opaque image.
const int BEHIND_STEPS = 3;

// The screen position (0..1) of the world point q; `own` where q is behind the camera.
vec2 screen_uv(vec3 q, vec2 own) {
    vec4 clip = u_proj * (u_view * vec4(q, 1.0));
    return clip.w > 0.0 ? clip.xy / clip.w * 0.5 + 0.5 : own;
}

// The G-buffer's view depth at the screen position uv (0: nothing drawn there).
float depth_at(vec2 uv) {
    ivec2 px = clamp(ivec2(uv * u_image_size), ivec2(0), ivec2(u_image_size) - 1);
    return texelFetch(u_transmission_depth, px, 0).r;
}
#endif

out vec4 frag_color;

void main() {
    // The material as the G-buffer pass stores it (glsl/passes/gbuffer.frag), two-sided.
#if VERTEX_COLOR
    vertex_color = v_color;
#endif
#if VERTEX_UV1
    vertex_uv1 = v_uv1;
#endif
#if ANALYTIC
    AnalyticHit hit = analytic_surface();   // as in passes/gbuffer.frag
    analytic_uv_ddx = hit.uv_ddx;
    analytic_uv_ddy = hit.uv_ddy;
    MaterialSample m = sample_material(hit.normal, hit.tangent, hit.uv, true);
    float view_depth = hit.view_depth;
    vec3 ng = hit.normal;   // the geometric normal: the shadow lookup's offset
    SAMPLE_FACTOR_TARGETS(hit.uv)   // as the G-buffer pass's RT6 and RT8, and glass's maps
#if ALPHA_BLEND || TRANSMISSION
    vec4 emission = sample_emission(hit.uv);   // lookups before any discard (derivatives)
#endif
#if ALPHA_BLEND
    float alpha = coverage(hit.uv);
#endif
    gl_FragDepth = hit.frag_depth;
    if (!hit.hit) discard;
#if ALPHA_MASK
    if (!(coverage(hit.uv) >= u_alpha_cutoff0)) discard;   // as passes/gbuffer.frag
#endif
#else
    MaterialSample m = sample_material(v_normal, v_tangent, v_uv, gl_FrontFacing);
    float view_depth = v_view_depth;
    // the geometric normal (the interpolated vertex normal, reversed on a back face as
    // sample_material reverses n): the shadow lookup's offset, never the mapped normal
    vec3 ng = gl_FrontFacing ? v_normal : -v_normal;
    SAMPLE_FACTOR_TARGETS(v_uv)   // as the G-buffer pass's RT6 and RT8, and glass's maps
#if ALPHA_BLEND || TRANSMISSION
    vec4 emission = sample_emission(v_uv);
#endif
#if ALPHA_BLEND
    float alpha = coverage(v_uv);
#endif
#if ALPHA_MASK
    if (!(coverage(v_uv) >= u_alpha_cutoff0)) discard;   // as passes/gbuffer.frag
#endif
#endif
#ifdef MODEL_GROUP
    // A part whose layers use two models is drawn once per model (forward_drawables in
    // app/render/blend.py): this draw keeps the fragments whose dominant layer uses its
    // model.
    if (fetch_model_group(u_materials, int(m.material_id)) != MODEL_GROUP) discard;
#endif
    Layer l = m.layer;
    vec3 t = m.t;
    // Sanitised as the lighting pass sanitises what the G-buffer delivers (a texture map can
    // hold anything, a degenerate mesh normal is NaN): the same values reach brdf_eval.
    Surface s = sanitize_surface(
        Surface(l.base_color, l.metallic, l.perceptual_roughness, l.f0, l.anisotropy));
    ModelParams params = fetch_model_params(u_materials, int(m.material_id));
    // The extension maps' factors on the row (app/common/extension_maps.py): RT6's and RT8's
    // as the lighting pass applies them, and under TRANSMISSION glTF transmissionTexture (R)
    // and thicknessTexture (G) on the row's transmission and thickness (a texel of 0 makes
    // the pixel opaque, or thin-walled)
    SCALE_BY_FACTOR_TARGETS(params)

    // The lighting pass's position: the pixel centre's view ray times the interpolated view
    // depth. An interpolated world position is as valid, but across the two 40 m triangles
    // of a floor its float32 barycentrics moved p by up to ~1e-4 of the distance to a
    // nearby light (measured), which hides the comparison with the deferred image.
    vec2 ndc_xy = (gl_FragCoord.xy / u_image_size) * 2.0 - 1.0;
    vec3 p = reconstruct_position(ndc_xy, view_depth, u_camera_pos, u_camera_to_world,
                                  u_tan_half_fov);
    vec3 v = normalize(u_camera_pos - p);
    vec3 n = sanitize_direction(m.n, v);
#if GBUFFER_COAT_NORMAL
    vec3 nc = sanitize_direction(m.nc, n);   // as the lighting pass decodes RT4
#else
    vec3 nc = n;
#endif
#if TRANSMISSION
    // KHR_materials_transmission: the diffuse share (1 - transmission) of the base; its
    // base colour tints the refracted light instead (exact for metallic 0; a metallic
    // part's F0 is scaled with it, docs/transmission.md).
    vec3 base_color = s.base_color;
    s.base_color *= 1.0 - params.transmission;
#endif
    ShadingPoint sp = ShadingPoint(s, params, n, nc, t, v, p);
    ng = sanitize_direction(normalize(ng), n);
#if TRANSMISSION
    vec3 radiance = surface_radiance(ivec2(0), emission, sp, ng);   // emission, occlusion too
    // The volume's thickness in world units: the object's, times the model matrix's scale
    // (the cube root of its determinant, a uniform scale exactly: per part, in float64 on
    // the CPU, MeshDrawable.thickness_scale).
    float thickness = params.thickness * u_thickness_scale;
    float focal_px = 0.5 * u_image_size.y / u_tan_half_fov.y;
    // One lookup per channel where the index disperses (KHR_materials_dispersion), else one.
    vec3 iors = dispersion_iors(params.eta_dielectric, params.dispersion);
    int lookups = params.dispersion > 0.0 ? 3 : 1;
    vec4 behind = vec4(0.0);
    vec2 own_uv = gl_FragCoord.xy / u_image_size;
    // the ray out of the volume at the material's index: the lookup's, where the index does
    // not disperse, and the lights' (below)
    TransmissionRay ray_out = transmission_ray(p, v, n, params.eta_dielectric, thickness);
    for (int c = 0; c < lookups; ++c) {
        float eta = lookups == 1 ? params.eta_dielectric : iors[c];
        TransmissionRay ray = lookups == 1 ? ray_out : transmission_ray(p, v, n, eta, thickness);
        vec2 uv = screen_uv(ray.exit, own_uv);
        float exit_depth = -(u_view * vec4(ray.exit, 1.0)).z;
        float far = depth_at(uv);
        float beyond = 0.0;   // the path from the exit to what the ray reaches
        if (thickness > 0.0) {
            // What the ray leaving the volume reaches: the point exit + s direction at the
            // opaque image's view depth there, by fixed-point steps from the exit's own
            // pixel (one step on a wall facing the camera); the background as far away.
            float rate = max(-(u_view * vec4(ray.direction, 0.0)).z, 0.05);
            for (int k = 0; k < BEHIND_STEPS; ++k) {
                beyond = far > 0.0 ? max(far - exit_depth, 0.0) / rate
                                   : 1e4 * max(exit_depth, 1e-6);
                uv = screen_uv(ray.exit + ray.direction * beyond, uv);
                far = depth_at(uv);
            }
        }
        // the rough lobe's footprint on what lies behind (its view depth; the background
        // as far away), over the path from p (brdf/transmission.glsl)
        far = far > 0.0 ? far : 1e4 * max(exit_depth, 1e-6);
        float path = thickness > 0.0 ? length(ray.exit - p) + beyond
                                     : max(far - exit_depth, 0.0);
        float lod = transmission_lod(s.perceptual_roughness, eta, thickness <= 0.0, path, far,
                                     focal_px);
        vec4 texel = textureLod(u_transmission_image, uv, lod);
        if (lookups == 1) {
            behind = texel;
        } else {
            behind[c] = texel[c];
            behind.a += texel.a / 3.0;
        }
    }
    vec3 weight = transmission_weight(s.f0_dielectric * params.specular_color,
                                      clamp(dot(n, v), 0.0, 1.0), params.transmission,
                                      s.metallic);
    vec3 transmittance = beer_lambert(params.attenuation_color, params.attenuation_distance,
                                      thickness);
    radiance += transmitted_radiance(behind.rgb, base_color, weight, transmittance);
    // Punctual lights seen through the surface (brdf/transmission.glsl transmitted_light:
    // the transmitted GGX lobe about each light mirrored through the surface), reaching
    // it from where the view ray leaves the volume, tinted as the light behind:
    //   pi sum_i base_color T(d) f_t(l_i, v) c_light_i |n.l_i|
    float alpha_t = transmission_alpha(material_alpha(s), params.eta_dielectric);
    vec3 through = vec3(0.0);
    for (int i = 0; i < u_light_count; ++i) {
        vec3 l;
        vec3 c_light = light_at(read_light(u_lights, i), ray_out.exit, l);
        through += transmitted_light(n, v, l, alpha_t, s.f0_dielectric * params.specular_color,
                                     params.transmission, s.metallic) * c_light;
    }
    radiance += PI * base_color * transmittance * through;
    // Premultiplied coverage: what shows through keeps the coverage of what is behind.
    float seen = dot(weight, vec3(1.0 / 3.0));
    frag_color = vec4(radiance, 1.0 - seen * (1.0 - behind.a));
#elif ALPHA_BLEND
    // C_src of "over": the lighting pass's radiance (lights/shading.glsl: the sum with
    // shadows, the environment's light, emission); the blend unit computes
    // alpha C_src + (1 - alpha) C_dst.
    frag_color = vec4(surface_radiance(ivec2(0), emission, sp, ng), alpha);
#else
    frag_color = vec4(surface_radiance(ivec2(0), vec4(0.0, 0.0, 0.0, 1.0), sp, ng), 1.0);
#endif
}
