// Area lights (rectangle, disk, sphere, tube) by linearly transformed cosines: Heitz,
// Dupuy, Hill and Neubelt 2016, "Real-Time Polygonal-Light Shading with Linearly
// Transformed Cosines". Compiled in only with AREA_LIGHTS (a frame with an area light:
// app/render/inputs.py AreaLightInput). Twin: app/reference/area_lights.py, same names.
//
// A light of radiance L adds integral f(l, v) L (n.l)+ dl over its solid angle. Both lobes
// are clamped-cosine integrals of the light's polygon (Lambert's edge formula): the
// diffuse one directly (the LTC of Lambert is the cosine itself), the GGX one after the
// polygon is transformed by the fitted M^-1 (scripts/ltc_tables.py, table u_ltc_table):
//   L_o / pi = L [ f_diffuse(l_rep) I(P) + (F0 (n_D - f_b) + f_b) I(M^-1 P) / pi ] / pi
// A sphere's I(P) is in closed form (sphere_form_factor); a clear coat adds its own lobe,
// the same table at the coat's roughness (area_coat_lobe), and weights the base's specular
// lobe through the coat (area_coat_weight).
#ifndef PBS_AREA_GLSL
#define PBS_AREA_GLSL

#include "common/constants.glsl"
#include "brdf/material.glsl"
#include "lights/punctual.glsl"

#if AREA_LIGHTS
// LTC_SIZE x LTC_SIZE cells per half: texel (j, i) holds M^-1's a, b, c, d and texel
// (LTC_SIZE + j, i) n_D, f_b at roughness row i, column j = sqrt(1 - n.v) (RGBA32F).
uniform sampler2D u_ltc_table;
// Texel i: light i's axis_v (app/common/lights.py pack_area_shapes).
uniform sampler2D u_area_shapes;

const float LTC_MIN_NOV = 1e-3;
// A disk's or sphere's polygon's sides by perceptual roughness (polygon_sides).
const int POLYGON_SIDES = 24;        // roughness < SIDES_ROUGH_12
const float SIDES_ROUGH_12 = 0.15;   // from here 12 sides
const float SIDES_ROUGH_8 = 0.25;    // from here 8 sides
const int TUBE_CAP_SIDES = 4;        // each of a tube's two half-polygon caps
const int MAX_POLYGON = 24;          // max(POLYGON_SIDES, 2 (TUBE_CAP_SIDES + 1))

// The table bilinearly between cell centres, by four texelFetch reads (no filtering
// hardware's reduced weight precision): (a, b, c, d) and (n_D, f_b).
void ltc_lookup(float roughness, float NoV, out vec4 m, out vec2 amp) {
    float r = clamp(roughness, MIN_PERCEPTUAL_ROUGHNESS, 1.0);
    float nov = clamp(NoV, LTC_MIN_NOV, 1.0);
    float x = (r - MIN_PERCEPTUAL_ROUGHNESS) / (1.0 - MIN_PERCEPTUAL_ROUGHNESS)
            * float(LTC_SIZE - 1);
    float y = sqrt(1.0 - nov) * float(LTC_SIZE - 1);
    int x0 = clamp(int(floor(x)), 0, LTC_SIZE - 2);
    int y0 = clamp(int(floor(y)), 0, LTC_SIZE - 2);
    float fx = x - float(x0);
    float fy = y - float(y0);
    vec4 m00 = texelFetch(u_ltc_table, ivec2(y0, x0), 0);
    vec4 m01 = texelFetch(u_ltc_table, ivec2(y0 + 1, x0), 0);
    vec4 m10 = texelFetch(u_ltc_table, ivec2(y0, x0 + 1), 0);
    vec4 m11 = texelFetch(u_ltc_table, ivec2(y0 + 1, x0 + 1), 0);
    m = mix(mix(m00, m01, fy), mix(m10, m11, fy), fx);
    vec2 a00 = texelFetch(u_ltc_table, ivec2(LTC_SIZE + y0, x0), 0).xy;
    vec2 a01 = texelFetch(u_ltc_table, ivec2(LTC_SIZE + y0 + 1, x0), 0).xy;
    vec2 a10 = texelFetch(u_ltc_table, ivec2(LTC_SIZE + y0, x0 + 1), 0).xy;
    vec2 a11 = texelFetch(u_ltc_table, ivec2(LTC_SIZE + y0 + 1, x0 + 1), 0).xy;
    amp = mix(mix(a00, a01, fy), mix(a10, a11, fy), fx);
}

// A unit vector perpendicular to unit a.
vec3 area_perpendicular(vec3 a) {
    vec3 helper = abs(a.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
    return normalize(cross(a, helper));
}

// The circumradius of the regular n-gon of a unit disk's area (the polygon keeps the area).
float disk_scale(int sides) {
    float n = float(sides);
    return sqrt(2.0 * PI / (n * sin(2.0 * PI / n)));
}

// A disk's or sphere's polygon's sides at this perceptual roughness: a smooth lobe sees
// the polygon's corners, a rough one does not.
int polygon_sides(float roughness) {
    return roughness < SIDES_ROUGH_12 ? POLYGON_SIDES : (roughness < SIDES_ROUGH_8 ? 12 : 8);
}

// The radius, over the tube's, of a half-polygon cap's inner vertices (its ends at the
// tube's radius) that gives the cap a half-disk's area (the twin's cap_scale).
float cap_scale(int sides) {
    float sin_d = sin(PI / float(sides));
    float qa = 0.5 * float(sides - 2) * sin_d;
    if (qa == 0.0) return 0.5 * PI / sin_d;
    return (-sin_d + sqrt(sin_d * sin_d + 2.0 * PI * qa)) / (2.0 * qa);
}

// The light's polygon's vertices relative to p (world), in the twin's order
// (light_polygon), a disk's or sphere's of ``sides`` sides; returns the vertex count.
int area_polygon(PunctualLight L, vec3 axis_v, vec3 p, int sides,
                 out vec3 verts[MAX_POLYGON]) {
    vec3 c = L.position;
    vec3 u = L.direction;   // axis_u: a rectangle's or disk's half extent, a tube's half axis
    vec3 w = axis_v;
    float r = L.cos_inner;  // radius (sphere, tube)
    if (L.type == LIGHT_RECT) {
        verts[0] = c - u - w - p;
        verts[1] = c + u - w - p;
        verts[2] = c + u + w - p;
        verts[3] = c - u + w - p;
        return 4;
    }
    if (L.type == LIGHT_DISK) {
        float k = disk_scale(sides);
        for (int i = 0; i < sides; ++i) {
            float a = 2.0 * PI * float(i) / float(sides);
            verts[i] = c + k * (cos(a) * u + sin(a) * w) - p;
        }
        return sides;
    }
    vec3 d = c - p;
    float dist = length(d);
    vec3 axis = d / max(dist, 1e-20);
    if (L.type == LIGHT_SPHERE) {
        // the silhouette circle: the cone tangent to the sphere, the same directions
        float d2 = max(dist * dist - r * r, 0.0);
        vec3 centre = d - (r * r / max(dist, 1e-20)) * axis;
        float rad = r * sqrt(d2) / max(dist, 1e-20) * disk_scale(sides);
        vec3 e1 = area_perpendicular(axis);
        vec3 e2 = cross(axis, e1);
        for (int i = 0; i < sides; ++i) {
            float a = 2.0 * PI * float(i) / float(sides);
            verts[i] = centre + rad * (cos(a) * e1 + sin(a) * e2);
        }
        return sides;
    }
    // tube: the axis segment widened perpendicular to it and to the point by the
    // cylinder's silhouette half-width, with half-polygon caps (a stadium; the twin's
    // docstring states the approximation)
    vec3 t = u / max(length(u), 1e-20);
    vec3 side = cross(t, axis);
    float side_len = length(side);
    side = side_len > 1e-9 ? side / side_len : area_perpendicular(t);
    // the half-width: the tangent planes' from p to the cylinder meet the plane through
    // the axis at r D / sqrt(D^2 - r^2), D p's distance to the axis line
    vec3 off_axis = d - dot(d, t) * t;
    float D2 = max(dot(off_axis, off_axis), 4.0 * r * r);
    float width = r * sqrt(D2 / (D2 - r * r));
    float k = width * cap_scale(TUBE_CAP_SIDES);
    for (int i = 0; i <= TUBE_CAP_SIDES; ++i) {
        float a = -0.5 * PI + PI * float(i) / float(TUBE_CAP_SIDES);
        // the ends at the half-width: the straight sides keep it
        float rad = (i == 0 || i == TUBE_CAP_SIDES) ? width : k;
        vec3 o = rad * (cos(a) * t + sin(a) * side);
        verts[i] = d + u + o;
        verts[TUBE_CAP_SIDES + 1 + i] = d - u - o;
    }
    return 2 * (TUBE_CAP_SIDES + 1);
}

// The edge's vector integral: angle(a, b) times the unit normal of the plane through a
// and b; the angle by atan of |a x b| and a.b, accurate for short edges (acos is not).
vec3 area_edge(vec3 a, vec3 b) {
    vec3 c = cross(a, b);
    float s = length(c);
    if (s <= 0.0) return vec3(0.0);
    return c * (atan(s, dot(a, b)) / s);
}

// The vector form factor of the convex polygon (n vertices, either winding) clipped to the
// horizon z >= 0; its z is the clamped-cosine integral I (made positive).
vec3 clipped_form_factor(vec3 verts[MAX_POLYGON], int n) {
    vec3 total = vec3(0.0);
    vec3 exit_pt = vec3(0.0);
    vec3 entry_pt = vec3(0.0);
    bool crossed = false;
    for (int i = 0; i < n; ++i) {
        vec3 a = verts[i];
        vec3 b = verts[i + 1 < n ? i + 1 : 0];
        float denom = a.z - b.z;
        vec3 x = a + (b - a) * (a.z / (denom == 0.0 ? 1.0 : denom));
        x.z = 0.0;
        bool above_a = a.z >= 0.0;
        bool above_b = b.z >= 0.0;
        if (above_a || above_b) {
            total += area_edge(above_a ? a : x, above_b ? b : x);
        }
        if (above_a && !above_b) {
            exit_pt = x;
            crossed = true;
        }
        if (!above_a && above_b) entry_pt = x;
    }
    if (crossed) total += area_edge(exit_pt, entry_pt);
    vec3 F = 0.5 * total;
    return F.z < 0.0 ? -F : F;
}

// M^-1 P for the fitted (a, b, c, d) of one polygon vertex x (local frame).
vec3 ltc_warp(vec4 m, vec3 x) {
    // M^-1 = [[a, 0, b], [0, c, 0], [d, 0, 1]]
    return vec3(m.x * x.x + m.y * x.z, m.z * x.y, m.w * x.x + x.z);
}

#if CLEARCOAT_ON
// What reaches the base's specular lobe through the coat and back at direction l (the
// light's representative one), as clearcoat_factors weights the punctual base: the twin's
// coat_weight.
vec3 area_coat_weight(ShadingPoint sp, vec3 l) {
    ModelParams p = sp.params;
    float NoL, NoV;
    vec3 h;
    shading_cosines(sp.nc, l, sp.v, NoL, NoV, h);
    float c = p.clearcoat;
    float F0c = clearcoat_F0(p.clearcoat_eta);
    float compression = 1.0;
    if ((CLEARCOAT_MODEL == CLEARCOAT_WEIDLICH_WILKIE
            || CLEARCOAT_MODEL == CLEARCOAT_WEIDLICH_WILKIE_SERIES) && c > 0.0) {
        compression = clearcoat_solid_angle_compression(mix(1.0, p.clearcoat_eta, c));
    }
    float T = T_clearcoat_filament(c, F0c, NoL, NoV);
    vec3 A = mix(vec3(1.0), A_clearcoat_beer_lambert(p.clearcoat_color, p.clearcoat_eta, NoL,
                                                     NoV), c);
    return (T * compression) * A;
}

// The clear coat's own lobe over the polygon (world, from p): c f_coat (nc.l)+ integrated
// by the LTC table at the coat's roughness in the coat normal's frame, over pi (twin:
// coat_lobe).
float area_coat_lobe(ShadingPoint sp, vec3 world[MAX_POLYGON], int count) {
    ModelParams p = sp.params;
    vec3 nc = sp.nc;
    vec3 t1 = sp.v - nc * dot(nc, sp.v);
    float t1_len = length(t1);
    t1 = t1_len > 1e-6 ? t1 / t1_len : area_perpendicular(nc);
    vec3 t2 = cross(nc, t1);
    vec4 m;
    vec2 amp;
    ltc_lookup(max(p.clearcoat_roughness, MIN_PERCEPTUAL_ROUGHNESS),
               clamp(dot(nc, sp.v), LTC_MIN_NOV, 1.0), m, amp);
    vec3 warped[MAX_POLYGON];
    for (int k = 0; k < count; ++k) {
        warped[k] = ltc_warp(m, vec3(dot(world[k], t1), dot(world[k], t2), dot(world[k], nc)));
    }
    float I_c = clipped_form_factor(warped, count).z;
    float F0c = clearcoat_F0(p.clearcoat_eta);
    return p.clearcoat * (F0c * (amp.x - amp.y) + amp.y) * (I_c / PI);
}
#endif

// The clamped-cosine integral of a sphere's cone of directions (half-angle sigma, at
// angle theta from the normal) clipped to the horizon, in closed form (Snyder 1996,
// "Area Light Sources for Real-Time Graphics"; Lagarde and de Rousiers 2014, "Moving
// Frostbite to PBR" 4.7.2); the twin's sphere_form_factor.
float sphere_form_factor(float cos_t, float sin2_sigma) {
    float c = clamp(cos_t, -1.0, 1.0);
    float s2 = clamp(sin2_sigma, 1e-30, 1.0);
    if (c * c > s2) return PI * s2 * max(c, 0.0);
    float sin_t = sqrt(max(1.0 - c * c, 1e-30));
    float x = sqrt(max(1.0 / s2 - 1.0, 0.0));
    float y = clamp(-x * c / sin_t, -1.0, 1.0);
    float q = sin_t * sqrt(1.0 - y * y);
    return max(s2 * (c * acos(y) - x * q) + atan(q, x), 0.0);
}

// f(l, v) L (n.l)+ integrated over area light i (L: its radiance, light.color), divided by
// pi: the term the illumination sum adds (it multiplies the sum by pi). A one-sided
// rectangle or disk lights only the side its normal u x v faces; the window falloff is
// the centre's, as a point light's, so the tiles cull it by its range. bv: brdf_view(sp),
// computed once before the point's light loop (its F0 and the diffuse lobe's factors).
vec3 area_light_term(PunctualLight light, int i, ShadingPoint sp, BrdfView bv) {
    vec3 axis_v = texelFetch(u_area_shapes, ivec2(i, 0), 0).xyz;
    vec3 p = sp.position;
    vec3 to_centre = light.position - p;
    if ((light.type == LIGHT_RECT || light.type == LIGHT_DISK)
            && dot(-to_centre, cross(light.direction, axis_v)) <= 0.0) {
        return vec3(0.0);
    }
    vec3 n = sp.n;
    vec3 t1 = sp.v - n * dot(n, sp.v);
    float t1_len = length(t1);
    t1 = t1_len > 1e-6 ? t1 / t1_len : area_perpendicular(n);
    vec3 t2 = cross(n, t1);
    // the polygon's sides by the smoothest lobe that sees it (a clear coat's, if smoother)
    float lobe_roughness = sp.s.perceptual_roughness;
#if CLEARCOAT_ON
    if (CLEARCOAT_MODEL != CLEARCOAT_NONE && sp.params.clearcoat > 0.0) {
        lobe_roughness = min(lobe_roughness, sp.params.clearcoat_roughness);
    }
#endif
    vec3 world[MAX_POLYGON];
    int count = area_polygon(light, axis_v, p, polygon_sides(lobe_roughness), world);
    vec3 local[MAX_POLYGON];
    vec3 warped[MAX_POLYGON];
    float NoV = clamp(dot(n, sp.v), LTC_MIN_NOV, 1.0);
    vec4 m;
    vec2 amp;
    ltc_lookup(sp.s.perceptual_roughness, NoV, m, amp);
    for (int k = 0; k < count; ++k) {
        vec3 x = vec3(dot(world[k], t1), dot(world[k], t2), dot(world[k], n));
        local[k] = x;
        // M^-1 = [[a, 0, b], [0, c, 0], [d, 0, 1]]
        warped[k] = vec3(m.x * x.x + m.y * x.z, m.z * x.y, m.w * x.x + x.z);
    }
    float I_d;
    vec3 l_rep;
    if (light.type == LIGHT_SPHERE) {
        // closed form; f_diffuse at the centre's direction, moved up to the horizon
        float d2 = dot(to_centre, to_centre);
        float r2 = light.cos_inner * light.cos_inner;
        vec3 axis = to_centre * inversesqrt(max(d2, 1e-30));
        float cos_t = dot(axis, n);
        I_d = d2 > r2 ? sphere_form_factor(cos_t, r2 / max(d2, 1e-30)) : 0.0;
        vec3 lifted = axis - n * min(cos_t, 0.0);
        l_rep = length(lifted) > 1e-6 ? normalize(lifted) : n;
    } else {
        // f_diffuse at the representative direction: the form factor's (exact for Lambert)
        vec3 F_d = clipped_form_factor(local, count);
        I_d = F_d.z;
        l_rep = I_d > 0.0 ? normalize(F_d.x * t1 + F_d.y * t2 + F_d.z * n) : n;
    }
    if (I_d <= 0.0) return vec3(0.0);
    float I_s = clipped_form_factor(warped, count).z;
    vec3 F0 = bv.F0;
#if CLEARCOAT_ON
    if (CLEARCOAT_MODEL != CLEARCOAT_NONE) {
        ShadingPoint base = clearcoat_base_point(sp, sp.v);  // F0 relative to the coat
        F0 = material_F0(base.s, base.params);
    }
#endif
    vec3 spec = (F0 * (amp.x - amp.y) + amp.y) * (I_s / PI);
#if CLEARCOAT_ON
    if (CLEARCOAT_MODEL != CLEARCOAT_NONE) {
        spec = area_coat_weight(sp, l_rep) * spec + vec3(area_coat_lobe(sp, world, count));
    }
#endif
    vec3 f_d = brdf_factors_view(sp, bv, l_rep).f_diffuse;
    vec3 Lo = selected_terms(f_d * I_d, spec);
    return Lo * light.color * (window_falloff(dot(to_centre, to_centre), light.range) / PI);
}
#endif

#endif
