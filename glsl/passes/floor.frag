// Floor pass (the bench's lower bound): the lighting pass's per-light term evaluated exactly
// once per (pixel, light in range) pair and nothing else. The pairs were found on the CPU,
// exactly, from the read-back G-buffer (app/bench/pairs.py) and uploaded untimed as one
// light mask per pixel; this pass decodes the G-buffer with the lighting pass's function and walks
// its pixel's mask with the lighting pass's own loop, where the tiled lighting pass walks
// its tile's mask, lights in range of the pixel or not.
//   L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+          (RTR4 sec. 9.4)
#include "brdf/brdf.glsl"
#include "gbuffer/decode.glsl"
#include "lights/illumination.glsl"

uniform sampler2D u_materials;     // RGBA32F, MATERIAL_TEXELS per material (app/common/material_fields.py)
uniform sampler2D u_lights;        // RGBA32F, 3 texels per light, one light per row
uniform usampler2D u_pixel_masks;  // RGBA32UI: TILE_QUADS texels per pixel (app/bench/floor.py)
uniform vec3 u_camera_pos;
uniform mat3 u_camera_to_world;
uniform vec2 u_tan_half_fov;     // tan(fov_y/2) * aspect, tan(fov_y/2)

out vec4 frag_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    // The lighting pass's decoding, sanitising included (docs/stability.md).
    ShadingPoint sp = decode_gbuffer(gl_FragCoord.xy, u_materials, u_camera_pos,
                                     u_camera_to_world, u_tan_half_fov);
    // FLOOR_LOCAL_ONLY: the scene has no directional light (app/bench/floor.py).
    vec3 Lo = add_masked_lights(vec3(0.0), u_pixel_masks, px, u_lights, 0,
                                FLOOR_LOCAL_ONLY != 0, sp, brdf_view(sp));
    frag_color = vec4(PI * Lo, 1.0);
}
