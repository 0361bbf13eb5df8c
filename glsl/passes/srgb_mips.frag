// One mip level of a colour map (GL_SRGB8_ALPHA8), drawn into level k from level k - 1
// (app/render/srgb_mips.py), in place of glGenerateMipmap: each texel the mean of its
// footprint's texels (common/footprint.glsl, each child weighted by the level-0 texels it
// covers) in linear light, as the GL's sRGB mips average: the fetch decodes sRGB, the
// framebuffer's sRGB encoding (GL_FRAMEBUFFER_SRGB) encodes the mean; alpha, linear,
// averaged as it is. llvmpipe compiles the GL's own mip blit anew in every process (its
// internal program is not in Mesa's shader cache); this program is.
#include "common/footprint.glsl"

uniform sampler2D u_above;  // level k - 1 alone (its level range set to it)
uniform ivec2 u_size0;      // level 0's size
uniform ivec2 u_child_size; // level k - 1's
uniform ivec2 u_size;       // level k's
uniform int u_level;        // k

out vec4 frag_color;

void main() {
    // Footprints in image rows (top first), as the CPU's mips and the normal chain's take
    // them; the texture holds its rows bottom first: output row j is image row h_k - 1 - j.
    ivec2 out_px = ivec2(gl_FragCoord.xy);
    ivec2 p = ivec2(out_px.x, u_size.y - 1 - out_px.y);
    ivec2 first = min(2 * p, u_child_size - 1);
    ivec2 last = ivec2(footprint_last_child(p.x, u_child_size.x, u_size.x),
                       footprint_last_child(p.y, u_child_size.y, u_size.y));
    vec4 sum = vec4(0.0);
    float total = 0.0;
    for (int y = first.y; y <= last.y; ++y) {
        for (int x = first.x; x <= last.x; ++x) {
            float w = footprint_texels(x, u_level - 1, u_child_size.x, u_size0.x)
                    * footprint_texels(y, u_level - 1, u_child_size.y, u_size0.y);
            sum += texelFetch(u_above, ivec2(x, u_child_size.y - 1 - y), 0) * w;
            total += w;
        }
    }
    frag_color = sum / total;
}
