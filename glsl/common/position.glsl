// World position of a pixel from the G-buffer's view depth. Twin: app/reference/position.py.
#ifndef PBS_POSITION_GLSL
#define PBS_POSITION_GLSL

// p = camera + z R (ndc.x tan_x, ndc.y tan_y, -1): the pixel's view ray scaled by the
// linear view depth z (metres along the view axis) that the G-buffer pass stored.
// Precision: a 24-bit window depth near 1 leaves ~1e-5 relative error in z after the
// perspective divide is undone (1 ulp of d over 1 - d), enough to move a sharp GGX
// highlight by 1e-3; a float32 linear depth keeps z to ~1e-7.
vec3 reconstruct_position(vec2 ndc_xy, float z, vec3 camera_pos, mat3 camera_to_world,
                          vec2 tan_half_fov) {
    vec3 ray = camera_to_world * vec3(ndc_xy * tan_half_fov, -1.0);
    return camera_pos + z * ray;
}

#endif
