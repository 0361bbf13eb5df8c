// Footprints of a mip level's texels, GL sizes (a side n_k = max(1, n >> k)), as the
// project's mips take them (app/textures/mips.py): along an axis, texel i of level k
// covers texels 2i and 2i + 1 of level k - 1, the last texel of an odd side > 1 also
// 2i + 2 (an odd last row or column joins the last pair), a side of 1 staying 1; so every
// texel of level 0 lies in exactly one footprint of each level.
#ifndef PBS_FOOTPRINT_GLSL
#define PBS_FOOTPRINT_GLSL

// The last texel of level k - 1 (of side n) under texel i of level k (of side size); the
// first is min(2 i, n - 1).
int footprint_last_child(int i, int n, int size) {
    if (n == 1) return 0;
    return 2 * i + 1 + ((i == size - 1 && (n & 1) == 1) ? 1 : 0);
}

// Level-0 texels under texel i of level k (of side size) along an axis of level-0 side
// n0: from i 2^k to (i + 1) 2^k, the last texel of the level to n0 (each odd remainder
// joins it).
float footprint_texels(int i, int k, int size, int n0) {
    int end = i == size - 1 ? n0 : (i + 1) << k;
    return float(end - (i << k));
}

#endif
