// Post pass: exposure, tone mapping, sRGB encoding of the HDR image.
#include "post/tonemap.glsl"

uniform sampler2D u_hdr;
uniform float u_exposure;   // linear scale, 2^EV

// Every tone map is white (or clamped) long before this; without the cap, radiance x 2^EV
// can overflow float32 inside a tone map (ACES squares its input: NaN past ~1.2e19).
const float MAX_EXPOSED = 1.0e9;

out vec4 frag_color;

void main() {
    vec3 c = min(texelFetch(u_hdr, ivec2(gl_FragCoord.xy), 0).rgb * u_exposure, MAX_EXPOSED);
#if TONEMAP == TONEMAP_NEUTRAL
    c = tonemap_khronos_neutral(c);
#elif TONEMAP == TONEMAP_ACES
    c = tonemap_aces_narkowicz(c);
#elif TONEMAP == TONEMAP_REINHARD
    c = tonemap_reinhard(c);
#endif
    frag_color = vec4(srgb_encode(c), 1.0);
}
