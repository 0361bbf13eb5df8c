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
vec3 perturb_normal(vec3 ng, vec3 t, float w, vec3 n_ts) {
    vec3 tt = t - ng * dot(ng, t);
    float tt_len = length(tt);
    if (!(tt_len > 1e-6)) return ng;
    tt /= tt_len;
    vec3 b = cross(ng, tt) * (w < 0.0 ? -1.0 : 1.0);
    return normalize(tt * n_ts.x + b * n_ts.y + ng * n_ts.z);
}

#endif
