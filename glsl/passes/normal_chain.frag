// One level of a normal/roughness chain (material/chain.glsl; app/render/normal_chain.py
// draws it once per level). CHAIN_STAGE 0: level 0, each texel the map's own; 1: level 1,
// from the map's texels; 2: level k from level k - 1's stored moments. Stages 1 and 2
// write the level's moments (location 0, float32) and its texels (location 1, float16).
//
// Footprints are those of app/textures/mips.py (common/footprint.glsl). Texels are indexed
// in image rows
// (top first); the maps' texels were uploaded so, and a level's texture holds its rows
// bottom first, as every map the GL samples: output row j is image row h_k - 1 - j. The
// moments keep the output's rows, so a child's image row y is texel row h_{k-1} - 1 - y.
#include "common/footprint.glsl"
#include "material/chain.glsl"

#ifdef CHAIN_TEXEL_BUFFERS
// The maps' texels read where they lie (app/gl/texel_buffer.py), row after row: texel
// (x, y) of level 0 is element y * width + x.
uniform samplerBuffer u_normals;    // the normal map's texels (RGBA UNORM, A unused)
uniform samplerBuffer u_roughness;  // the roughness image's texels (RGBA UNORM): green
#else
uniform sampler2D u_normals;    // the normal map's texels (RGB UNORM), image rows
uniform sampler2D u_roughness;  // the roughness channel (R UNORM), image rows
#endif
uniform bool u_has_roughness;   // else u_factor alone
uniform float u_factor;         // the material's roughness factor
uniform float u_scale;          // the material's normal scale
uniform sampler2D u_moments;    // stage 2: the level before's moments, its one level
uniform ivec2 u_size0;          // level 0's size
uniform ivec2 u_child_size;     // the level before's size (stage 0: level 0's)
uniform ivec2 u_size;           // this level's size
uniform int u_level;            // this level's index k

#if CHAIN_STAGE == 0
out vec4 chain_out;
#else
layout(location = 0) out vec4 moments_out;
layout(location = 1) out vec4 chain_out;
#endif

#ifdef CHAIN_TEXEL_BUFFERS
vec3 normal_texel(ivec2 p) { return texelFetch(u_normals, p.y * u_size0.x + p.x).rgb; }
float roughness_texel(ivec2 p) { return texelFetch(u_roughness, p.y * u_size0.x + p.x).g; }
#else
vec3 normal_texel(ivec2 p) { return texelFetch(u_normals, p, 0).rgb; }
float roughness_texel(ivec2 p) { return texelFetch(u_roughness, p, 0).r; }
#endif

float roughness_at(ivec2 p) {
    return u_factor * (u_has_roughness ? roughness_texel(p) : 1.0);
}

void main() {
    ivec2 out_px = ivec2(gl_FragCoord.xy);
    ivec2 p = ivec2(out_px.x, u_size.y - 1 - out_px.y);  // image rows
#if CHAIN_STAGE == 0
    vec3 n = chain_normal(normal_texel(p), u_scale);
    chain_out = vec4(n, roughness_at(p));
#else
    ivec2 first = min(2 * p, u_child_size - 1);
    ivec2 last = ivec2(footprint_last_child(p.x, u_child_size.x, u_size.x),
                       footprint_last_child(p.y, u_child_size.y, u_size.y));
    ChainMoments m = chain_empty();
    if (all(lessThan(p, u_size - 1))) {
        // A texel short of the last row and column: a 2x2 block of children of equal
        // weight (only the last texel of a level takes an odd remainder), merged at once.
#if CHAIN_STAGE == 1
        vec2 s[4];
        float a2 = 0.0;
        for (int i = 0; i < 4; ++i) {
            ivec2 c = first + ivec2(i & 1, i >> 1);
            s[i] = chain_slope(chain_normal(normal_texel(c), u_scale));
            float r = roughness_at(c);
            a2 += (r * r) * (r * r);
        }
        m = chain_block4(s, float[4](0.0, 0.0, 0.0, 0.0), a2 * 0.25);
#else
        vec2 s[4];
        float v[4];
        float a2 = 0.0;
        for (int i = 0; i < 4; ++i) {
            vec4 child = texelFetch(u_moments, ivec2(first.x + (i & 1),
                                                     u_child_size.y - 1 - first.y - (i >> 1)), 0);
            s[i] = child.xy;
            v[i] = child.z;
            a2 += child.w;
        }
        m = chain_block4(s, v, a2 * 0.25);
#endif
    } else {
        for (int y = first.y; y <= last.y; ++y) {
            for (int x = first.x; x <= last.x; ++x) {
#if CHAIN_STAGE == 1
                ivec2 c = ivec2(x, y);
                vec2 s = chain_slope(chain_normal(normal_texel(c), u_scale));
                float r = roughness_at(c);
                float r2 = r * r;
                m = chain_merge(m, 1.0, s, 0.0, r2 * r2);
#else
                vec4 child = texelFetch(u_moments, ivec2(x, u_child_size.y - 1 - y), 0);
                float w = footprint_texels(x, u_level - 1, u_child_size.x, u_size0.x)
                        * footprint_texels(y, u_level - 1, u_child_size.y, u_size0.y);
                m = chain_merge(m, w, child.xy, child.z, child.w);
#endif
            }
        }
    }
    vec4 stored = chain_stored(m);
    moments_out = stored;
    chain_out = chain_texel(stored);
#endif
}
