// Technique `shexp`: the declarations its shade pass (shade.glsl) and its receiver-cluster pass
// (clusters.glsl) share: the order-n tables, the blocker BVH, the parameters, the cluster cut lists.
#ifndef SHEXP_BINDINGS_GLSL
#define SHEXP_BINDINGS_GLSL
#include "../../common/sh.glsl"
#ifndef SHEXP_N
#define SHEXP_N 4
#endif
#ifndef BVH_STACK_SIZE
#define BVH_STACK_SIZE 32
#endif
#include "../../common/bvh.glsl"

layout(std430, binding = 10) readonly buffer ShGamma { uvec2 sh_gamma[]; };
layout(std430, binding = 11) readonly buffer ShOl { vec2 sh_ol[]; };
layout(std430, binding = 12) readonly buffer ShCircle { float sh_circle[]; };
layout(std430, binding = 13) readonly buffer BvhNodes { BvhNode bvh_nodes[]; };
// Twin: engine::passes::shade::shexp::GpuShexpParams.
struct ShexpParams {
    uint sphere_count;
    float sin_theta_max;   // SHEXP Eq. 36 (0: leaves only)
    uint exp_method;       // 0 hyb, 1 ol, 2 ps*
    int ps_degree;         // p of PS*-p
    float hyb_target;      // ‖f̂‖ after HYB's scaling
    float ol_norm_max;     // the OL table's last ‖f̂‖
    uint gamma_count;      // entries of the Γ table
    uint diffuse_mode;     // 0 sh, 1 ratio
    float large_u;         // u = 1 − cos θ above which a sphere multiplies its visibility (large=product; 2: never)
    uint accumulate;       // 0 log (the paper), 1 product (Zhou et al. 2005: every sphere multiplies g)
    float sin_theta_min;   // theta_min: nodes and spheres subtending less are dropped (0: none)
    uint cluster;          // receiver clusters (SHEXP §6.3): tile side T (0: a cut per receiver)
    uint ratio_vectors;    // 1: W from Eq. 37; 0: W = 1 (the cut's nodes block as their bounding spheres)
    uint vertex_clusters;  // clusters of the per-vertex target (VertexCluster* below)
    uint pixel_world;      // 1: per pixel, the vertex clusters (pixel_clusters=world)
    uint alpha_scale;      // 1: the §6.2 rule with the radius scale α (blocker_for_receiver_alpha)
    uint bake;             // 1: a receiver whose cluster's cut did not change keeps its g (bake=on)
    float reach;           // bounded reach (common/bvh.glsl), scene units; 0: off
    uint pad4;
    uint pad5;
    vec4 h_star[2];        // irradiance weighting H*_l (SHEXP Eq. 9), l = 0..7
    vec4 window[2];        // window factors α_l applied to the lights' caps (the environment's are baked)
};
layout(std430, binding = 14) readonly buffer ShexpParamsBuf { ShexpParams shx; };
// The environment's windowed order-n projection, RGB (w = 0), n² records.
layout(std430, binding = 15) readonly buffer EnvSh { vec4 env_sh[]; };
#define SHN_GAMMA(e) sh_gamma[e]
#define SHN_GAMMA_COUNT shx.gamma_count
#define SHN_OL(k) sh_ol[k]
#define SHN_OL_COUNT 256
#define SHN_OL_NORM_MAX shx.ol_norm_max
#define SHN_CIRCLE_SEGMENTS 12
#define SHN_CIRCLE_SAMPLES 64
#define SHN_CIRCLE(e, c) sh_circle[(e) * (SHEXP_N + 1) + (c)]
#include "../../common/shexp_n.glsl"

// Receiver clusters (SHEXP §6.3, `cluster` > 0), written by clusters.glsl and read by shade.glsl: per
// cluster a head (x: entries, y: 0, or 1 when its cut exceeded SHEXP_CLUSTER_CAP entries or 2 when the
// shared pool of entries ran out, and its receivers then cut per point; z: receivers in it; w: its first
// entry in the pool) and its entries in the pool, each a blocker sphere of the cut (a leaf or a node taken
// whole) with its ratio vector W (Eq. 37), w_l for l = 0..7. The pool's use is counted in ClusterPool
// (zeroed before the cluster pass). Twin: engine::passes::shade::shexp::cpu::ClusterCut.
#define SHEXP_CLUSTER_CAP 512
// Retries of a cluster's cut past the cap, each with sin θ_max doubled (twin: shexp::CLUSTER_COARSEN).
#define SHEXP_CLUSTER_COARSEN 4
struct ClusterEntry {
    vec4 sphere;
    vec4 w_lo;  // w_0..w_3
    vec4 w_hi;  // w_4..w_7
};
layout(std430, binding = 22) buffer ClusterHeads { uvec4 cluster_heads[]; };
layout(std430, binding = 23) buffer ClusterCut { ClusterEntry cluster_cut[]; };
layout(std430, binding = 25) buffer ClusterPool { uint cluster_pool_used; };
// The per-vertex target's clusters (engine::passes::shade::shexp::vertex_clusters: spatial groups of at most
// T² vertices of one instance): cluster c holds vertices vc_items[vc_offsets[c] .. vc_offsets[c + 1]];
// vc_of[v] is vertex v's cluster.
layout(std430, binding = 26) readonly buffer VertexClusterOffsets { uint vc_offsets[]; };
layout(std430, binding = 27) readonly buffer VertexClusterItems { uint vc_items[]; };
layout(std430, binding = 28) readonly buffer VertexCluster { uint vc_of[]; };
// pixel_clusters=world: per cluster, how far its triangles reach past its vertices
// (vertex_clusters::pixel_reach); the cluster pass grows the bounding sphere by it.
layout(std430, binding = 29) readonly buffer VertexClusterReach { float vc_reach[]; };
// Work counts (twin: engine::passes::shade::shexp::ClusterStats): clusters with receivers, cut entries,
// the largest cut, clusters over the cap, nodes taken whole, clusters the pool could not hold.
layout(std430, binding = 24) buffer ShexpStats { uint shexp_stats[8]; };
// bake=on (§7, static receivers keep their visibility): per cluster the hash of its last cut (entries with W,
// count, state; 0: none yet), and per receiver (vertex, or pixel row-major) its last visibility record: g
// (SHN_C floats), the blockers counted, and the position and shading normal it was computed for
// (engine::passes::shade::shexp::BAKE_EXTRA). Fewer records than receivers: no baking (shade.glsl checks).
layout(std430, binding = 30) buffer ClusterHashes { uvec2 cluster_hashes[]; };
layout(std430, binding = 31) buffer ShexpBaked { float shexp_baked[]; };
#define SHEXP_BAKE_STRIDE (SHN_C + 7)
// Cluster head flag (head.y bit 2): the cut equals the last frame's (bake=on).
#define SHEXP_CLUSTER_UNCHANGED 4u

#endif // SHEXP_BINDINGS_GLSL
