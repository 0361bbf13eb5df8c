// The environment behind the objects: every pixel the G-buffer left empty shows the
// environment's radiance towards its view ray, bilinear from the equirect map (no mips:
// a background pixel covers under a texel at the sizes the project renders).
#include "common/constants.glsl"
#include "env/equirect.glsl"

uniform sampler2D g_depth;          // the G-buffer's (view depth, material id)
uniform sampler2D u_environment;    // RGBA32F equirect map, LINEAR, repeat in u
uniform mat3 u_camera_to_world;
uniform vec2 u_tan_half_fov;
uniform float u_rotation;           // radians about +Y
uniform float u_intensity;

out vec4 frag_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(g_depth, px, 0).r;
    // covered pixels keep what the lighting pass wrote (decode_gbuffer's test, negated)
    if (!isnan(depth) && !isinf(depth) && depth > 0.0) discard;
    vec2 ndc = gl_FragCoord.xy / vec2(textureSize(g_depth, 0)) * 2.0 - 1.0;
    vec3 d = normalize(u_camera_to_world * vec3(ndc * u_tan_half_fov, -1.0));
    frag_color = vec4(u_intensity * texture(u_environment, equirect_uv(d, u_rotation)).rgb, 1.0);
}
