// Shadow pass of an alpha-masked part (glTF 2.0 alphaMode MASK): the fragment is absent
// where the layer's coverage is below its cutoff, exactly as in the G-buffer pass
// (passes/gbuffer.frag), so that a cut-out casts the shadow of what the camera sees of it.
// Depth only. Vertex stage: passes/gbuffer.vert with u_view the identity and u_proj the
// light's matrix (app/render/shadows.py _MaskedCaster).
#ifndef ALPHA_MASK
#define ALPHA_MASK 1   // every part drawn with this shader is masked
#endif
#include "material/layers.glsl"

in vec2 v_uv;
#if VERTEX_COLOR
in vec4 v_color;
#endif
#if VERTEX_UV1
in vec2 v_uv1;
#endif

void main() {
#if VERTEX_COLOR
    vertex_color = v_color;   // COLOR_0's A multiplies the coverage
#endif
#if VERTEX_UV1
    vertex_uv1 = v_uv1;
#endif
    if (!(coverage(v_uv) >= u_alpha_cutoff0)) discard;
}
