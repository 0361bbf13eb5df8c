// A normal map's and a roughness map's joint mip chain, built on the GL (RTR4 sec. 9.13,
// "Blending and Filtering Materials"): the "variance" method of app/textures/mips.py, the
// float64 chain the drawn one is held to as a whole; each function's float64 twin, of the
// same name, is in app/reference/chain.py (the per-texel formulas: app/reference/filtering.py).
// Each texel of level k holds what its footprint's source texels give together: the mean
// slope s = -n.xy / n.z, the slopes' total variance Var(s.x) + Var(s.y) and the mean
// alpha^2 = r^4 (LEAN-style moments, Olano & Baker 2010); its normal is the mean slope's
// and its roughness alpha'^2 = min(1, alpha^2 + 2 sigma^2) with sigma^2 the per-axis
// variance (Beckmann: a lobe of roughness alpha has slope variance alpha^2 / 2 per axis).
// Precision: the moments are float32, and a footprint's are merged from its children's
// means and variances (Chan, Golub & LeVeque 1979, the pairwise update), not as E[s^2] -
// E[s]^2, whose difference of two float32 sums would lose the small variance of a
// steep but even footprint.
#ifndef PBS_CHAIN_GLSL
#define PBS_CHAIN_GLSL

// The smallest tangent-space n.z (app/textures/mips.py MIN_NORMAL_Z): decoded normals are
// raised to it, and slopes divide by n.z floored to it (|slope| <= 20).
const float CHAIN_MIN_NORMAL_Z = 0.05;

// A glTF normal-map texel (UNORM: each channel v / 255) as a unit tangent-space normal:
// v / 255 * 2 - 1 normalised, n.z raised to the floor (x, y rescaled to keep unit length),
// then the material's normal scale on x, y and normalised again (decode_normal_map and
// maps._map_chain_levels). No channel decodes to 0, so the vector has a length.
vec3 chain_normal(vec3 unorm, float scale) {
    vec3 n = normalize(unorm * 2.0 - 1.0);
    if (n.z < CHAIN_MIN_NORMAL_Z) {
        n.xy *= sqrt(1.0 - CHAIN_MIN_NORMAL_Z * CHAIN_MIN_NORMAL_Z) / length(n.xy);
        n.z = CHAIN_MIN_NORMAL_Z;
    }
    if (scale != 1.0) {
        n.xy *= scale;
        n = normalize(n);
    }
    return n;
}

// The slope of a unit normal, n.z floored to CHAIN_MIN_NORMAL_Z.
vec2 chain_slope(vec3 n) {
    return -n.xy / max(n.z, CHAIN_MIN_NORMAL_Z);
}

// A running merge of weighted footprints (Chan et al.'s pairwise update): the weight so
// far, the mean slope, the sum of squared deviations of the slopes (both axes together)
// and the weighted sum of alpha^2.
struct ChainMoments {
    float weight;
    vec2 mean;
    float deviations;
    float alpha2;
};

ChainMoments chain_empty() {
    return ChainMoments(0.0, vec2(0.0), 0.0, 0.0);
}

// m merged with a part of weight w, mean slope s, total slope variance v and mean alpha^2 a2.
ChainMoments chain_merge(ChainMoments m, float w, vec2 s, float v, float a2) {
    float total = m.weight + w;
    vec2 d = s - m.mean;
    m.mean += d * (w / total);
    m.deviations += v * w + dot(d, d) * (m.weight * w / total);
    m.alpha2 += a2 * w;
    m.weight = total;
    return m;
}

// Four parts of equal weight at once (a 2x2 block of texels of one level, mean slopes s,
// total slope variances v, mean alpha^2 a2): the mean of the means, and the variance of the
// whole, the mean of the variances plus that of the means about their mean (Chan et al.'s
// update for equal weights, in two passes over the four). Weight 1: chain_stored reads
// means from it as from a running merge.
ChainMoments chain_block4(vec2 s[4], float v[4], float a2) {
    vec2 mean = 0.25 * ((s[0] + s[1]) + (s[2] + s[3]));
    float spread = 0.0;
    for (int i = 0; i < 4; ++i) {
        vec2 d = s[i] - mean;
        spread += v[i] + dot(d, d);
    }
    return ChainMoments(1.0, mean, 0.25 * spread, a2);
}

// The moments as a level stores them: (mean s.x, mean s.y, total variance, mean alpha^2).
vec4 chain_stored(ChainMoments m) {
    return vec4(m.mean, m.deviations / m.weight, m.alpha2 / m.weight);
}

// A level's texel from its stored moments: the normal of the mean slope, (-s.x, -s.y, 1)
// normalised, and the perceptual roughness alpha'^(1/2) of alpha'^2 = min(1, alpha^2 +
// 2 sigma^2), sigma^2 = (Var(s.x) + Var(s.y)) / 2 (alpha2_from_slope_variance).
vec4 chain_texel(vec4 stored) {
    float alpha2 = min(1.0, stored.w + max(stored.z, 0.0));
    return vec4(normalize(vec3(-stored.xy, 1.0)), sqrt(sqrt(alpha2)));
}

#endif
