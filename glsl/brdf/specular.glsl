// The specular microfacet BRDF. Twin: app/reference/specular.py.
#ifndef PBS_SPECULAR_GLSL
#define PBS_SPECULAR_GLSL

// Cook & Torrance 1982; seed section 8:
//   f_spec = F(h, l) G2(l, v, h) D(h) / (4 |n.l| |n.v|),  h = (l + v)/|l + v|,
// with GGX D, height-correlated Smith G2 (as the visibility V = G2/(4|n.l||n.v|))
// and Schlick F. n.l > 0 is the caller's guarantee; n.v is clamped to MIN_N_DOT_V.
vec3 f_spec_GGX(vec3 F0, float alpha, vec3 n, vec3 l, vec3 v) {
    vec3 h = normalize(l + v);
    float NoL = clamp(dot(n, l), 0.0, 1.0);
    float NoV = clamp(dot(n, v), MIN_N_DOT_V, 1.0);
    float D = D_GGX(n, h, alpha);
    float V = V_height_correlated_GGX(NoL, NoV, alpha);
    vec3 F = F_schlick(F0, dot(l, h));
    return F * (D * V);
}

#endif
