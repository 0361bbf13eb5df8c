// Thin-lens depth of field (RTR4 sec. 9.2, the camera): the circle of confusion.
// Twin: app/reference/dof.py (which derives the formula).
#ifndef PBS_DOF_GLSL
#define PBS_DOF_GLSL

// Radius in pixels of the disc a thin lens of aperture diameter `aperture` (m), focused
// at `focus` (m), images a point at view depth z into; z <= 0 or non-finite is the
// background (z -> infinity). `scale` = H / (2 tan(fov_y / 2)); clamped to max_coc.
float coc_radius(float z, float aperture, float focus, float scale, float max_coc) {
    bool far = !(z > 0.0 && z < 3.0e38);
    float r = far ? aperture / (2.0 * focus)
                  : aperture * abs(z - focus) / (2.0 * z * focus);
    return min(r * scale, max_coc);
}

#endif
