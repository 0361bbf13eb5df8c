// One face of one mip level of the GGX-prefiltered environment cube map (docs/ibl.md):
// L_pre(R) ~ sum_i L(l_i) (R.l_i) / sum_i (R.l_i) over GGX-distributed half vectors h_i
// around R with n = v = R (Karis 2013's split sum; RTR4 sec. 10.5.2), each sample read
// from the equirect source's mip chain at the level whose texels cover the sample's share
// of the lobe (filtered importance sampling, Krivanek & Colbert 2008, "Real-time Shading
// with Filtered Importance Sampling", eq. 10 with their +1 bias). Float64 reference: the
// exact sum over texels, app/reference/ibl.py prefiltered_radiance.
#include "common/constants.glsl"
#include "env/cube.glsl"
#include "env/equirect.glsl"

uniform sampler2D u_source;      // equirect RGBA32F with its whole mip chain
uniform int u_face;              // 0..5 = +X, -X, +Y, -Y, +Z, -Z
uniform float u_roughness;       // perceptual; alpha = r^2
uniform int u_samples;
uniform int u_face_size;          // this level's face size in texels

out vec4 frag_color;

// The i-th of n points of the Hammersley set (radical inverse in base 2).
vec2 hammersley(int i, int n) {
    uint b = uint(i);
    b = (b << 16u) | (b >> 16u);
    b = ((b & 0x55555555u) << 1u) | ((b & 0xAAAAAAAAu) >> 1u);
    b = ((b & 0x33333333u) << 2u) | ((b & 0xCCCCCCCCu) >> 2u);
    b = ((b & 0x0F0F0F0Fu) << 4u) | ((b & 0xF0F0F0F0u) >> 4u);
    b = ((b & 0x00FF00FFu) << 8u) | ((b & 0xFF00FF00u) >> 8u);
    return vec2((float(i) + 0.5) / float(n), float(b) * 2.3283064365386963e-10);
}

void main() {
    vec3 R = normalize(cube_direction(u_face, gl_FragCoord.xy / float(u_face_size)));
    if (u_roughness <= 0.0) {  // the mirror level: the source itself
        frag_color = vec4(textureLod(u_source, equirect_uv(R, 0.0), 0.0).rgb, 1.0);
        return;
    }
    float a2 = u_roughness * u_roughness * u_roughness * u_roughness;  // alpha^2
    vec3 up = abs(R.y) < 0.999 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
    vec3 tx = normalize(cross(up, R));
    vec3 ty = cross(R, tx);
    vec2 size = vec2(textureSize(u_source, 0));
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    for (int i = 0; i < u_samples; ++i) {
        vec2 xi = hammersley(i, u_samples);
        // GGX half vectors: cos^2 theta_h = (1 - xi) / (1 + (alpha^2 - 1) xi)
        // (Walter et al. 2007, eqs. 35-36), phi uniform.
        float cos2 = (1.0 - xi.y) / (1.0 + (a2 - 1.0) * xi.y);
        float sin_h = sqrt(max(1.0 - cos2, 0.0));
        float phi = 2.0 * PI * xi.x;
        vec3 h = (cos(phi) * sin_h) * tx + (sin(phi) * sin_h) * ty + sqrt(cos2) * R;
        vec3 l = 2.0 * dot(R, h) * h - R;
        float NoL = dot(R, l);
        if (NoL <= 0.0) continue;
        // pdf(l) = D(h) (n.h) / (4 v.h) = D(h) / 4 with n = v = R
        float d = cos2 * (a2 - 1.0) + 1.0;
        float pdf = a2 / (4.0 * PI * d * d);
        // the sample's solid angle against an equirect texel's at its latitude
        float omega_s = 1.0 / (float(u_samples) * pdf);
        float omega_p = 2.0 * PI * PI * sqrt(max(1.0 - l.y * l.y, 1e-6)) / (size.x * size.y);
        float lod = max(0.5 * log2(omega_s / omega_p) + 1.0, 0.0);
        sum += textureLod(u_source, equirect_uv(l, 0.0), lod).rgb * NoL;
        weight += NoL;
    }
    frag_color = vec4(sum / max(weight, 1e-8), 1.0);
}
