// Diffuse (subsurface) terms. Twin: app/reference/diffuse.py.
#ifndef PBS_DIFFUSE_GLSL
#define PBS_DIFFUSE_GLSL

// Lambert 1760; seed section 3: f = rho_ss / pi, whose directional albedo is rho_ss.
vec3 Fd_lambert(vec3 rho_ss) {
    return rho_ss * INV_PI;
}

#endif
