// Analytic primitives in the G-buffer (and the bench's forward) pass: a convex proxy mesh
// around the primitive is rasterised, and every fragment intersects its pixel's view ray
// with the exact surface, so the normal, tangent frame, UVs and depth are the surface's own,
// not a tessellation's. Conventions (normal, tangent, UVs): app/common/primitives.py; the
// float64 ray-caster that checks them is app/reference/raycast.py (written apart).
#ifndef PBS_ANALYTIC_GLSL
#define PBS_ANALYTIC_GLSL

#include "common/constants.glsl"

#ifndef ANALYTIC_SPHERE
#define ANALYTIC_SPHERE 0
#endif
// Any analytic primitive: its UVs are computed per pixel.
#define ANALYTIC ANALYTIC_SPHERE

#if ANALYTIC
// The hit's UV derivatives, set by the pass before it samples the material's maps
// (material/layers.glsl samples with them instead of the implicit ones).
vec2 analytic_uv_ddx;
vec2 analytic_uv_ddy;
#endif

// The camera, as the lighting pass reconstructs positions (common/position.glsl): the ray
// through a pixel centre is camera_to_world (ndc.x tan_x, ndc.y tan_y, -1), whose
// component along the view axis is 1, so a hit's ray parameter IS its view depth.
uniform vec3 u_camera_pos;
uniform mat3 u_camera_to_world;
uniform vec2 u_tan_half_fov;        // tan(fov_y/2) * aspect, tan(fov_y/2)
uniform vec2 u_image_size;          // pixels of the target
uniform mat4 u_proj;
// The primitive: the camera in its object space (computed in float64 on the CPU, so no
// float32 product of the inverse model matrix with a distant camera enters the hit), the
// linear part of world -> object, and its size; passes/gbuffer.vert's u_model and
// u_normal_matrix take the frame back to the world.
uniform vec3 u_object_camera;
uniform mat3 u_camera_to_object;    // world -> object (linear part) times camera -> world
uniform float u_radius;
// The ray through the primitive's centre, for a far camera (ray_from_centre).
uniform float u_centre_depth;       // the centre's view depth; <= 0: not used
uniform vec2 u_centre_pixel;        // the centre's window position, pixels
uniform vec3 u_centre_direction;    // object space, its view-axis component 1
uniform mat4 u_model;
uniform mat3 u_normal_matrix;
uniform float u_tangent_sign;

// One pixel's intersection. Where the ray misses, `hit` is false and the other fields hold
// the surface point nearest to the ray, so that a quad's screen-space derivatives stay
// meaningful at silhouettes; the caller discards the fragment only after its derivatives.
struct AnalyticHit {
    bool hit;
    vec3 normal;        // world, unnormalised (as an interpolated vertex normal would be)
    vec4 tangent;       // world xyz along +u, w = handedness
    vec2 uv;
    vec2 uv_ddx;        // screen-space derivatives of uv, continuous across the u seam
    vec2 uv_ddy;
    float view_depth;   // metres along the view axis
    float frag_depth;   // window depth for gl_FragDepth
    // How far the ray passes inside the silhouette, r - |f| (object units; negative for a
    // miss): smooth across the silhouette, zero on it (render.antialiasing = "gbaa").
    float inside;
};

// d(u)/dx of a longitude coordinate u in [0, 1): across the seam u jumps by 1, so the
// derivative of u and of u shifted by half a turn are both taken and the smaller kept
// (wherever one of them jumps, the other does not).
vec2 seam_free_gradient(float u, float v) {
    float u_shifted = fract(u + 0.5);
    vec2 du = vec2(dFdx(u), dFdy(u));
    vec2 du_shifted = vec2(dFdx(u_shifted), dFdy(u_shifted));
    return vec2(abs(du.x) <= abs(du_shifted.x) ? du.x : du_shifted.x,
                abs(du.y) <= abs(du_shifted.y) ? du.y : du_shifted.y);
}

// The ray o + t d against the sphere |q| = r in object space, d not unit (the model
// matrix may scale). Haines, Guenther & Akenine-Moeller 2019, "Precision Improvements for
// Ray/Sphere Intersection" (Ray Tracing Gems ch. 7): the discriminant b^2 - a c equals
// a (r^2 - |f|^2) with f = o - (b/a) d the ray's point nearest the centre, which avoids
// subtracting two nearly equal squares for a distant camera; the near root is c / q, where
// q = -(b + sign(b) sqrt(disc)) does not cancel. Returns (near t, far t, r^2 - |f|^2).
vec3 ray_sphere(vec3 o, vec3 d, float r) {
    float a = dot(d, d);
    float b = dot(o, d);             // half of the usual b
    float c = dot(o, o) - r * r;
    vec3 f = o - (b / a) * d;
    float lf = length(f);
    float h = (r - lf) * (r + lf);   // r^2 - |f|^2 without cancelling
    float s = sqrt(a * max(h, 0.0));
    float q = -(b + (b >= 0.0 ? s : -s));
    float t0 = c / q;
    float t1 = q / a;
    return vec3(min(t0, t1), max(t0, t1), h);
}

// The pixel's ray in object space as w + u d, whose view depth is t0 + u. From the camera,
// w is the camera's object-space position and t0 = 0; but a camera far from a primitive
// (sec1's stands 300 m from half-metre spheres) makes every point near the primitive a
// difference of two large float32 numbers, and the normal lost ~1e-4 rad that way. So
// where the primitive's centre lies ahead of the camera the ray is written around the ray
// through the centre: with d_c that ray's direction and t_c the centre's view depth
// (o = -t_c d_c exactly, as the ray meets the centre), the pixel's direction is
// d = d_c + delta, delta coming from the pixel's offset from the centre's own pixel, and
// o + t d = t_c delta + (t - t_c) d: only small numbers, exact for any distance.
void pixel_ray_at(vec2 window, out vec3 w, out vec3 d, out float t0) {
    if (u_centre_depth > 0.0) {
        vec2 offset = (window - u_centre_pixel) * (2.0 / u_image_size);
        vec3 delta = u_camera_to_object * vec3(offset * u_tan_half_fov, 0.0);
        d = u_centre_direction + delta;
        w = u_centre_depth * delta;
        t0 = u_centre_depth;
    } else {
        vec2 ndc = (window / u_image_size) * 2.0 - 1.0;
        d = u_camera_to_object * vec3(ndc * u_tan_half_fov, -1.0);
        w = u_object_camera;
        t0 = 0.0;
    }
}

// The ray through the pixel centre.
void pixel_ray(out vec3 w, out vec3 d, out float t0) {
    pixel_ray_at(gl_FragCoord.xy, w, d, t0);
}

AnalyticHit analytic_surface() {
    vec3 o, d;
    float t0;
    pixel_ray(o, d, t0);
    AnalyticHit h;
#if ANALYTIC_SPHERE
    vec3 roots = ray_sphere(o, d, u_radius);
    float t = t0 + roots.x;
    // Only the near surface of the closed sphere is seen, as with a mesh whose back faces
    // are culled: a camera inside the sphere (near root behind the near plane) sees nothing.
    // The projection's near and far planes clip it as they clip a mesh.
    float near = u_proj[3][2] / (u_proj[2][2] - 1.0);
    float far = u_proj[3][2] / (u_proj[2][2] + 1.0);
    h.hit = roots.z >= 0.0 && t >= near && t <= far;
    // A miss keeps the point of the sphere nearest the ray (for the derivatives below).
    vec3 q = roots.z >= 0.0 ? o + roots.x * d : o - (dot(o, d) / dot(d, d)) * d;
    vec3 n_obj = normalize(q);
    // The object-space tangent runs around +Y (X at the poles, where Y x n vanishes).
    vec3 t_obj = cross(vec3(0.0, 1.0, 0.0), n_obj);
    t_obj = dot(t_obj, t_obj) > 1e-12 ? t_obj : cross(vec3(1.0, 0.0, 0.0), n_obj);
    // World: normals by the inverse transpose, tangents with the surface (as a mesh's).
    h.normal = u_normal_matrix * n_obj;
    h.tangent = vec4(mat3(u_model) * t_obj, u_tangent_sign);
    float u = atan(n_obj.x, n_obj.z) * (0.5 / PI) + 0.5;
    float v = atan(n_obj.y, length(n_obj.xz)) / PI + 0.5;   // asin(n.y), stable at the poles
    h.uv = vec2(u, v);
    vec2 du = seam_free_gradient(u, v);
    h.uv_ddx = vec2(du.x, dFdx(v));
    h.uv_ddy = vec2(du.y, dFdy(v));
    h.view_depth = h.hit ? t : 0.0;
    // r^2 - |f|^2 = (r - |f|)(r + |f|), divided by r + |f| without cancelling
    h.inside = roots.z / (u_radius + sqrt(max(u_radius * u_radius - roots.z, 0.0)));
#endif
    // Window depth of view depth z: ndc_z = (P22 (-z) + P32) / z, depth range [0, 1].
    h.frag_depth = clamp(0.5 * (-u_proj[2][2] + u_proj[3][2] / max(h.view_depth, 1e-30)) + 0.5,
                         0.0, 1.0);
    return h;
}

#if ANALYTIC_SPHERE && defined(GBUFFER_SAMPLE_MASK)
// A multisampled geometry pass (render.antialiasing = "sraa", app/render/antialias.py):
// the pixel's samples the sphere covers, each ray-cast at its own position in the pixel
// (u_sample_positions, the target's, in pixels from the pixel's corner), as a bit mask
// for gl_SampleMask; a discard or depth of the centre alone would give every sample the
// centre's coverage and leave the sphere's edge aliased. ``depth``: the view depth of
// the first covered sample (0 where none is covered).
uniform vec2 u_sample_positions[GBUFFER_SAMPLE_MASK];

int analytic_sample_mask(out float depth) {
    float near = u_proj[3][2] / (u_proj[2][2] - 1.0);
    float far = u_proj[3][2] / (u_proj[2][2] + 1.0);
    int mask = 0;
    depth = 0.0;
    for (int i = 0; i < GBUFFER_SAMPLE_MASK; ++i) {
        vec3 o, d;
        float t0;
        pixel_ray_at(floor(gl_FragCoord.xy) + u_sample_positions[i], o, d, t0);
        vec3 roots = ray_sphere(o, d, u_radius);
        float t = t0 + roots.x;
        if (roots.z >= 0.0 && t >= near && t <= far) {
            if (mask == 0) depth = t;
            mask |= 1 << i;
        }
    }
    return mask;
}
#endif

#endif
