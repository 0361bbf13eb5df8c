// Tangent-space normal mapping (OpenGL convention: +x along +u, +y along +v, +z along the
// surface normal). Twin: app/reference/normal_mapping.py.
#ifndef PBS_NORMAL_MAPPING_GLSL
#define PBS_NORMAL_MAPPING_GLSL

// The unit tangent-space normal a filtered normal-map texel stands for. Trilinear filtering
// averages unit normals and shortens them; the mip's roughness already holds the spread
// that the shortening stands for (app/textures/mips.py), so the direction is renormalised.
// A texel of length 0 (not produced by the project's maps) stands for the unperturbed +z.
vec3 tangent_space_normal(vec3 texel) {
    float len = length(texel);
    return len > 0.0 ? texel / len : vec3(0.0, 0.0, 1.0);
}

// Mikkelsen 2008, "Simulation of Wrinkled Surfaces Revisited" (the frame glTF and
// MikkTSpace use): the unit geometric normal ng, the unit tangent t along +u (or 0 where
// the mesh has none) and the handedness w of (t, b, n) give the frame t' = t - ng (ng.t)
// renormalised, b = w' cross(ng, t') with w' = -1 for w < 0 and +1 otherwise; the mapped
// normal is normalize(t' n_ts.x + b n_ts.y + ng n_ts.z). Where t' is shorter than 1e-6
// (no tangent, or one along the normal) the frame is undefined and ng is returned.
// Precision: t' is a difference of float32 vectors, so a tangent within ~1e-3 rad of the
// normal leaves its direction to rounding (a relative error of ~1e-7 / |t'|).
// tangent_frame gives that frame (t', b), false where it is undefined; perturb_normal
// the mapped normal.
bool tangent_frame(vec3 ng, vec3 t, float w, out vec3 tt, out vec3 b) {
    tt = t - ng * dot(ng, t);
    float tt_len = length(tt);
    b = vec3(0.0);
    if (!(tt_len > 1e-6)) return false;
    tt /= tt_len;
    b = cross(ng, tt) * (w < 0.0 ? -1.0 : 1.0);
    return true;
}

vec3 perturb_normal(vec3 ng, vec3 t, float w, vec3 n_ts) {
    vec3 tt, b;
    if (!tangent_frame(ng, t, w, tt, b)) return ng;
    return normalize(tt * n_ts.x + b * n_ts.y + ng * n_ts.z);
}

// glTF KHR_materials_anisotropy (RTR4 sec. 9.8, anisotropic NDFs): the direction of
// anisotropy in the tangent plane. `dir` is a 2D direction in the frame (t', b) of
// perturb_normal above (+x along t', +y along b = sign(w) cross(ng, t')); the result is the
// unit world-space tangent t' dir.x + b dir.y, i.e. t' turned about ng towards b by
// atan(dir.y, dir.x) when dir is a unit vector. Where the frame is undefined (|t'| <= 1e-6)
// t is returned unchanged. The lighting pass orthonormalises it against the shading normal.
vec3 rotate_tangent(vec3 ng, vec3 t, float w, vec2 dir) {
    vec3 tt, b;
    if (!tangent_frame(ng, t, w, tt, b)) return t;
    return normalize(tt * dir.x + b * dir.y);
}

// The unit direction an anisotropy direction map's filtered texel stands for: the texel
// holds the decoded glTF value 2 rg - 1 (app/textures/maps.py); filtering shortens it, so
// it is renormalised, and a texel of length 0 stands for the tangent itself, (1, 0).
vec2 anisotropy_direction(vec2 texel) {
    float len = length(texel);
    return len > 0.0 ? texel / len : vec2(1.0, 0.0);
}

#endif
