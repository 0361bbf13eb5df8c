// G-buffer pass, fragment stage: writes the material parameters of the nearest surface.
// The targets: app/common/gbuffer.py GBUFFER_TARGETS (docs/gbuffer.md).
#include "common/encoding.glsl"
#include "geometry/analytic.glsl"
#include "geometry/edge.glsl"
#include "material/layers.glsl"

in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
in float v_view_depth;
#if VERTEX_COLOR
in vec4 v_color;
#endif
#if VERTEX_UV1
in vec2 v_uv1;
#endif
#if GBUFFER_EDGE_GEOMETRY
// The triangle's barycentric coordinates, linear in window space; which of its edges can
// be a silhouette; the neighbours' far edges (passes/gbuffer_edge.geom)
noperspective in vec3 v_edge_barycentric;
flat in vec3 v_edge_kind;
flat in vec3 v_edge_beyond[6];
#endif


// layout(location = i) out vecN g_<target>; of every target present, at the location
// app/render/gbuffer.py binds it (app/common/gbuffer.py GBUFFER_TARGETS). With constant surfaces the
// material table's row carries the surface numbers: no g_base_color, g_normal a vec2.
GBUFFER_OUTPUTS

void main() {
#if VERTEX_COLOR
    vertex_color = v_color;   // material/layers.glsl multiplies base colour and coverage
#endif
#if VERTEX_UV1
    vertex_uv1 = v_uv1;       // the maps that read TEXCOORD_1 (UV_SET1_MAPS0)
#endif
#if ANALYTIC
    // The exact surface under the pixel centre (geometry/analytic.glsl); the proxy's
    // interpolated attributes are unused.
    AnalyticHit hit = analytic_surface();
    analytic_uv_ddx = hit.uv_ddx;
    analytic_uv_ddy = hit.uv_ddy;
    vec2 uv = hit.uv;
    MaterialSample m = sample_material(hit.normal, hit.tangent, uv, true);
    float view_depth = hit.view_depth;
#else
    vec2 uv = v_uv;
    MaterialSample m = sample_material(v_normal, v_tangent, uv, gl_FrontFacing);
    float view_depth = v_view_depth;
#endif
    Layer l = m.layer;
#if GBUFFER_EDGE && ANALYTIC
    // The ray's distance inside the sphere's silhouette, r - |f|, is smooth across it:
    // to first order its zero is the silhouette (the quad's helper lanes give the slope).
    g_edge = edge_distances(hit.inside, vec2(dFdx(hit.inside), dFdy(hit.inside)));
#elif GBUFFER_EDGE_GEOMETRY
    // Each direction leaves the triangle through the edge nearest that way (each
    // barycentric coordinate is linear in window space and zero on the edge opposite its
    // vertex): a silhouette's distance is the answer, and past an inner edge the surface
    // goes on, unless the neighbour beyond is the last before a smooth mesh's rim (a
    // sliver on screen): then the way out of it through its far edges (window lines).
    vec3 bx = dFdx(v_edge_barycentric), by = dFdy(v_edge_barycentric);
    vec4 exits[3];
    for (int j = 0; j < 3; ++j) exits[j] = edge_distances(v_edge_barycentric[j], vec2(bx[j], by[j]));
    vec4 first = min(min(exits[0], exits[1]), exits[2]);
    g_edge = vec4(EDGE_FAR);
    for (int j = 0; j < 3; ++j) {
        bvec4 through = equal(exits[j], first);
        if (v_edge_kind[j] == EDGE_SILHOUETTE) g_edge = mix(g_edge, exits[j], through);
    }
    // Where a direction leaves through a rim edge, the way on through the sliver's far
    // edges: each direction follows only its own exit edge's two lines (picked per
    // component), not every rim edge's six. One branch for the whole triangle: where no
    // edge is a rim the loop below ends after its first turn (llvmpipe runs a loop only
    // while a lane of the block is in it).
    if (any(equal(v_edge_kind, vec3(EDGE_RIM)))) {
        bvec4 rim = bvec4(false);
        vec4 fa = vec4(0.0), fb = vec4(0.0);   // the two far lines' values
        vec4 ax = vec4(0.0), ay = vec4(0.0), bx_ = vec4(0.0), by_ = vec4(0.0);   // normals
        for (int j = 0; j < 3; ++j) {
            bvec4 through = v_edge_kind[j] == EDGE_RIM ? equal(exits[j], first) : bvec4(false);
            vec3 a = v_edge_beyond[2 * j], b = v_edge_beyond[2 * j + 1];
            fa = mix(fa, vec4(dot(a.xy, gl_FragCoord.xy) + a.z), through);
            fb = mix(fb, vec4(dot(b.xy, gl_FragCoord.xy) + b.z), through);
            ax = mix(ax, vec4(a.x), through);
            ay = mix(ay, vec4(a.y), through);
            bx_ = mix(bx_, vec4(b.x), through);
            by_ = mix(by_, vec4(b.y), through);
            rim = bvec4(uvec4(rim) | uvec4(through));
        }
        // edge_distances of each line, its slope per direction as there
        vec4 sa = vec4(-ax.x, ax.y, -ay.z, ay.w), sb = vec4(-bx_.x, bx_.y, -by_.z, by_.w);
        vec4 da = mix(vec4(EDGE_FAR), clamp(fa / max(sa, vec4(1e-30)), 0.0, EDGE_FAR),
                      greaterThan(sa, vec4(0.0)));
        vec4 db = mix(vec4(EDGE_FAR), clamp(fb / max(sb, vec4(1e-30)), 0.0, EDGE_FAR),
                      greaterThan(sb, vec4(0.0)));
        g_edge = mix(g_edge, max(first, min(da, db)), rim);
    }
#elif GBUFFER_EDGE
    g_edge = vec4(EDGE_FAR);
#endif
#if GBUFFER_CONSTANT_SURFACES
    // The layer's constants, which the decode reads from the pixel's table row instead.
#if GBUFFER_UNORM_DIRECTIONS
    g_normal = snorm_to_unorm(oct_encode(m.n));
#else
    g_normal = oct_encode(m.n);
#endif
#else
    g_base_color = vec4(l.base_color, l.metallic);
#if GBUFFER_UNORM_DIRECTIONS
    // 16-bit unorm targets (docs/gbuffer.md, "Encodings"): signed values mapped into
    // [0, 1]; NaN given the fallback the decode's sanitize_surface would give it.
    g_normal = vec4(snorm_to_unorm(oct_encode(m.n)), finite_or(l.perceptual_roughness, 1.0),
                    finite_or(l.f0, 0.04));
#else
    g_normal = vec4(oct_encode(m.n), l.perceptual_roughness, l.f0);
#endif
#endif
    g_depth = vec2(view_depth, m.material_id);
#if GBUFFER_TANGENT
    // Interpolation shortens the tangent and may tilt it off the surface; the lighting
    // pass re-orthonormalises it against n, so only its direction matters here.
#if GBUFFER_UNORM_DIRECTIONS
    g_tangent = vec4(snorm_to_unorm(oct_encode(m.t)),
                     snorm_to_unorm(clamp(finite_or(l.anisotropy, 0.0), -1.0, 1.0)), 0.0);
#else
    g_tangent = vec4(oct_encode(m.t), l.anisotropy, 0.0);
#endif
#endif
#if GBUFFER_COAT_NORMAL
#if GBUFFER_UNORM_DIRECTIONS
    g_coat_normal = snorm_to_unorm(oct_encode(m.nc));
#else
    g_coat_normal = oct_encode(m.nc);
#endif
#endif
#if GBUFFER_EMISSION
    g_emission = sample_emission(uv);
#endif
    // RT6, RT8: each G-buffer factor target's sample_<target>(uv) (material/layers.glsl,
    // generated from app/common/extension_maps.py; nothing where none is present)
    WRITE_FACTOR_TARGETS(uv)
#if ALPHA_MASK
    // glTF 2.0 alphaMode MASK: the surface is absent where its coverage is below the
    // cutoff (after the lookups above, whose derivatives need the whole quad).
    if (!(coverage(uv) >= u_alpha_cutoff0)) discard;
#endif
#if ANALYTIC && defined(GBUFFER_SAMPLE_MASK)
    // A multisampled target: each sample's own coverage; a pixel whose centre misses
    // takes the depth of a sample it covers (only RT2's depth and id are read there).
    float sample_depth;
    int mask = analytic_sample_mask(sample_depth);
    if (mask == 0) discard;
    gl_SampleMask[0] = mask;
    if (!hit.hit) {
        g_depth = vec2(sample_depth, m.material_id);
        hit.frag_depth = clamp(0.5 * (-u_proj[2][2] + u_proj[3][2] / sample_depth) + 0.5,
                               0.0, 1.0);
    }
    gl_FragDepth = hit.frag_depth;
#elif ANALYTIC
    // After every derivative above, so that a missing pixel still served its quad.
    gl_FragDepth = hit.frag_depth;
    if (!hit.hit) discard;
#endif
}
