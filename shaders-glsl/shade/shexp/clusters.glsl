// Technique `shexp`, receiver clusters (SHEXP §6.3 "Per-cluster computation"): one workgroup of 64 per
// cluster, before the shade pass. A cluster is a T×T screen tile (per pixel, clusters_pixel.comp) or a
// spatial group of at most T² vertices of one instance (per vertex, clusters_vertex.comp; vertex_clusters.rs),
// T = shx.cluster. With pixel_clusters=world the per-pixel target uses the vertex clusters too
// (clusters_vertex.comp): a pixel joins the cluster of its triangle's first vertex, and the bounding sphere
// grows by the cluster's reach (vc_reach) so that it holds the cluster's triangles.
// 1. The receivers' bounding sphere (p_R, r_R): the centre of their bounding box and the largest distance
//    from it; the central point p* is the receiver nearest that centre (lowest index on ties).
// 2. One cut of the blocker BVH for the whole cluster (thread 0): a node is taken whole when it subtends
//    less than θ_max from every point of the bounding sphere (Eq. 36: r_i < sin θ_max (‖P_i − p_R‖ − r_R)),
//    leaves always; a node smaller than θ_min from every point is dropped. At most SHEXP_CLUSTER_CAP
//    entries, taken from a pool shared by the clusters: past the cap the cut is retried with sin θ_max
//    doubled, up to SHEXP_CLUSTER_COARSEN times (capped at 1); past that, or when the pool is used up, the
//    cluster is marked overflowed and its receivers cut per point as with cluster = 0
//    (both counted).
// 3. The ratio vector W of each node taken whole (threads in parallel): the bounding log vector f_b of its
//    sphere at p* and the detailed f_d = Σ of its leaves' circle logs at p* (leaves below θ_min from p*
//    dropped), then per band w_l = Σ_m f_b,lm f_d,lm / Σ_m f_b,lm² (Eq. 37). A leaf has W = 1. Both are
//    the raw logs (no tangent-plane rule): p* lies outside every node taken whole, and the §6.2 rules are
//    applied per receiver in shade.glsl to the node's sphere, which W then scales (Eq. 38).
// 4. bake=on: a hash of the cut (every entry's sphere and W in order, the count, the state), compared with
//    the cluster's hash of the last frame; equal marks the cluster unchanged (head.y bit 2) for the shade pass.
// f64 twin: engine::passes::shade::shexp::cpu::Twin::cluster_cut.
#define BVH_STACK_SIZE 64
#include "../common.glsl"
#include "bindings.glsl"

layout(local_size_x = 64) in;
// grow_by_reach 1: the clusters serve the per-pixel target (pixel_clusters=world), 0: their own vertices.
// bake 1: bake=on with records for this target's receivers (the cuts are hashed and compared with the last
// frame's).
layout(push_constant) uniform ClusterPush {
    uint grow_by_reach;
    uint bake;
} cluster_push;

uint cluster_side() {
    return max(shx.cluster, 1u);
}

// Receiver k (0 ≤ k < T²) of cluster c: false when there is none (off screen, background, past the last
// vertex, not finite).
bool cluster_item(uint c, uint k, out vec3 p) {
    uint t = cluster_side();
    p = vec3(0.0);
#ifdef SHEXP_CLUSTER_PIXEL
    uint tiles_x = (frame.size.x + t - 1u) / t;
    uvec2 px = uvec2(c % tiles_x, c / tiles_x) * t + uvec2(k % t, k / t);
    if (any(greaterThanEqual(px, frame.size.xy))) return false;
    vec4 q = imageLoad(gbuf_position, ivec2(px));
    if (!(q.w >= 0.5)) return false;
    p = q.xyz;
#else
    uint first = vc_offsets[c];
    if (k >= min(vc_offsets[c + 1u] - first, t * t)) return false;
    uint i = vc_items[first + k];
    if (i >= frame.vertex_count) return false;
    p = world[i].position.xyz;
#endif
    return !(any(isnan(p)) || any(isinf(p)));
}

shared vec3 s_lo[64];
shared vec3 s_hi[64];
shared float s_r[64];
shared float s_d[64];
shared uint s_k[64];
shared uint s_nodes[SHEXP_CLUSTER_CAP];
shared uint s_count;
shared uint s_base;
shared uint s_state;
shared uvec2 s_hash[64];

// One 32-bit word into a running hash (a multiply–xorshift mixer, two lanes with different constants).
uvec2 hash_word(uvec2 h, uint x) {
    h ^= uvec2(x);
    h *= uvec2(0x9e3779b1u, 0x85ebca77u);
    h ^= h >> 15u;
    h *= uvec2(0xc2b2ae3du, 0x27d4eb2fu);
    return h ^ (h >> 13u);
}

// W of node v at p* (see 3. above).
void ratio_vector(uint v, vec3 ps, out float w[8]) {
    for (int l = 0; l < 8; ++l) w[l] = 1.0;
    BvhNode nd = bvh_nodes[v];
    if (bvh_is_leaf(nd) || shx.ratio_vectors == 0u) return;
    vec4 s = bvh_sphere(nd);
    float ub = shn_sphere_u(ps, s);
    if (!(ub > 0.0 && ub < 1.0)) return;
    float fb[SH_MAX_ORDER];
    shn_circle_fstar(ub, fb);
    float yb[SHN_C];
    shn_eval(s.xyz - ps, yb);
    float fd[SHN_C];
    for (int i = 0; i < SHN_C; ++i) fd[i] = 0.0;
    BvhCursor cur;
    cur.size = 1u;
    cur.stack[0] = v;
    cur.overflowed = false;
    uint u;
    while (bvh_cursor_next(cur, u)) {
        BvhNode m = bvh_nodes[u];
        vec4 q = bvh_sphere(m);
        if (q.w < shx.sin_theta_min * distance(ps, q.xyz)) continue;
        if (bvh_is_leaf(m) || !bvh_cursor_push_children(cur, m.left, m.right)) {
            shn_add_circle_log(fd, shn_sphere_u(ps, q), q.xyz - ps);
        }
    }
    for (int l = 0; l < SHEXP_N; ++l) {
        float num = 0.0, yy = 0.0;
        for (int i = l * l; i < (l + 1) * (l + 1); ++i) {
            num += yb[i] * fd[i];
            yy += yb[i] * yb[i];
        }
        float den = fb[l] * fb[l] * yy;
        w[l] = abs(fb[l]) > 1e-30 && den > 1e-30 ? fb[l] * num / den : 1.0;
    }
}

// The dispatch is 2D, this many clusters per row (twin: CLUSTERS_PER_ROW in shexp/mod.rs).
#define SHEXP_CLUSTERS_PER_ROW 1024u

uint cluster_total() {
    uint t = cluster_side();
#ifdef SHEXP_CLUSTER_PIXEL
    return ((frame.size.x + t - 1u) / t) * ((frame.size.y + t - 1u) / t);
#else
    return shx.vertex_clusters;
#endif
}

void main() {
    uint c = gl_WorkGroupID.y * SHEXP_CLUSTERS_PER_ROW + gl_WorkGroupID.x;
    // Uniform per workgroup: the last row's spare workgroups leave before any barrier.
    if (c >= cluster_total()) return;
    uint tid = gl_LocalInvocationID.x;
    uint t = cluster_side();
    bvh_reach = shx.reach;
    uint items = t * t;

    // 1. Bounding box, then the bounding sphere about its centre and the receiver nearest the centre.
    vec3 lo = vec3(3.0e38), hi = vec3(-3.0e38);
    for (uint k = tid; k < items; k += 64u) {
        vec3 p;
        if (cluster_item(c, k, p)) {
            lo = min(lo, p);
            hi = max(hi, p);
        }
    }
    s_lo[tid] = lo;
    s_hi[tid] = hi;
    barrier();
    for (uint h = 32u; h > 0u; h >>= 1) {
        if (tid < h) {
            s_lo[tid] = min(s_lo[tid], s_lo[tid + h]);
            s_hi[tid] = max(s_hi[tid], s_hi[tid + h]);
        }
        barrier();
    }
    bool empty = s_hi[0].x < s_lo[0].x;
    vec3 centre = 0.5 * (s_lo[0] + s_hi[0]);
    float r = 0.0, dmin = 3.0e38;
    uint kmin = 0xffffffffu;
    uint valid = 0u;
    for (uint k = tid; k < items; k += 64u) {
        vec3 p;
        if (cluster_item(c, k, p)) {
            float d = distance(p, centre);
            r = max(r, d);
            if (d < dmin) {
                dmin = d;
                kmin = k;
            }
            valid += 1u;
        }
    }
    s_r[tid] = r;
    s_d[tid] = dmin;
    s_k[tid] = kmin;
    barrier();
    for (uint h = 32u; h > 0u; h >>= 1) {
        if (tid < h) {
            s_r[tid] = max(s_r[tid], s_r[tid + h]);
            float d = s_d[tid + h];
            uint k = s_k[tid + h];
            if (d < s_d[tid] || (d == s_d[tid] && k < s_k[tid])) {
                s_d[tid] = d;
                s_k[tid] = k;
            }
        }
        barrier();
    }
    float radius = s_r[0];
    // pixel_clusters=world: the pixels of the cluster's triangles lie within their reach of its vertices.
    if (cluster_push.grow_by_reach != 0u) radius += vc_reach[c];
    vec3 ps = centre;
    if (!empty) cluster_item(c, s_k[0], ps);

    // 2. The cluster's cut.
    if (tid == 0u) {
        uint count = 0u;
        bool overflow = false;
        uint whole = 0u;
        // A cut past the cap is retried with sin θ_max doubled (at most SHEXP_CLUSTER_COARSEN times, up to 1):
        // coarser, but still the cluster's cut with ratio vectors, which agrees with the clusters around it.
        // The per-receiver cut of an overflowed cluster has no ratio vectors: its nodes taken whole (groups of
        // characters' bounding spheres) would darken whole tiles of `crowd`.
        float sin_max = shx.sin_theta_max;
        for (uint attempt = 0u; !empty && shx.sphere_count > 0u; ++attempt) {
            count = 0u;
            overflow = false;
            whole = 0u;
            vec4 receiver = vec4(centre, radius);
            BvhCursor cur = bvh_cursor_begin(shx.sphere_count);
            uint v;
            while (bvh_cursor_next(cur, v)) {
                BvhNode nd = bvh_nodes[v];
                vec4 s = bvh_sphere(nd);
                if (s.w < shx.sin_theta_min * (distance(centre, s.xyz) - radius)) continue;
                // Bounded reach (bvh.glsl): beyond it from every receiver of the cluster.
                if (bvh_reach > 0.0 && distance(centre, s.xyz) - s.w - radius >= bvh_reach) continue;
                bool leaf = bvh_is_leaf(nd);
                if (leaf || bvh_subtends_less_than(receiver, s, sin_max)
                    || !bvh_cursor_push_children(cur, nd.left, nd.right)) {
                    if (count == uint(SHEXP_CLUSTER_CAP)) {
                        overflow = true;
                        break;
                    }
                    s_nodes[count] = v;
                    count += 1u;
                    if (!leaf) whole += 1u;
                }
            }
            if (!overflow || attempt >= uint(SHEXP_CLUSTER_COARSEN) || !(sin_max > 0.0) || sin_max >= 1.0) break;
            sin_max = min(2.0 * sin_max, 1.0);
        }
        uint state = overflow ? 1u : 0u;
        uint base = 0u;
        if (!overflow && count > 0u) {
            base = atomicAdd(cluster_pool_used, count);
            if (base + count > uint(cluster_cut.length())) state = 2u;
        }
        if (state != 0u) {
            count = 0u;
            whole = 0u;
        }
        s_count = count;
        s_base = base;
        s_state = state;
        cluster_heads[c] = uvec4(count, state, 0u, base);
        if (!empty) {
            atomicAdd(shexp_stats[0], 1u);
            atomicAdd(shexp_stats[1], count);
            atomicMax(shexp_stats[2], count);
            if (state == 1u) atomicAdd(shexp_stats[3], 1u);
            atomicAdd(shexp_stats[4], whole);
            if (state == 2u) atomicAdd(shexp_stats[5], 1u);
        }
    }
    memoryBarrierShared();
    barrier();

    // 3. Ratio vectors, one entry per thread at a time.
    uint count = s_count;
    uint base = s_base;
    uvec2 hash = uvec2(0u);
    for (uint e = tid; e < count; e += 64u) {
        uint v = s_nodes[e];
        float w[8];
        ratio_vector(v, ps, w);
        ClusterEntry ce;
        ce.sphere = bvh_sphere(bvh_nodes[v]);
        ce.w_lo = vec4(w[0], w[1], w[2], w[3]);
        ce.w_hi = vec4(w[4], w[5], w[6], w[7]);
        cluster_cut[base + e] = ce;
        // bake=on: the entry, with its place in the list, into this thread's share of the cut's hash.
        if (cluster_push.bake == 0u) continue;
        uvec2 h = hash_word(uvec2(0x2545f491u, 0x4f1bbcddu), e);
        for (int k = 0; k < 4; ++k) h = hash_word(h, floatBitsToUint(ce.sphere[k]));
        for (int k = 0; k < 4; ++k) h = hash_word(h, floatBitsToUint(ce.w_lo[k]));
        for (int k = 0; k < 4; ++k) h = hash_word(h, floatBitsToUint(ce.w_hi[k]));
        hash ^= h;
    }
    // bake=on: the cut's hash (XOR of its entries' hashes, then its count and state); the cluster is
    // unchanged when it equals the last frame's. The shade pass then reuses its unmoved receivers' records.
    s_hash[tid] = hash;
    barrier();
    for (uint h = 32u; h > 0u; h >>= 1) {
        if (tid < h) s_hash[tid] ^= s_hash[tid + h];
        barrier();
    }
    if (tid == 0u && cluster_push.bake != 0u) {
        uvec2 cut_hash = hash_word(hash_word(s_hash[0], count), s_state);
        cut_hash.x |= 1u;  // never 0, the "no cut yet" of a fresh buffer
        bool unchanged = s_state == 0u && !empty && cluster_hashes[c] == cut_hash;
        cluster_hashes[c] = cut_hash;
        if (unchanged) {
            cluster_heads[c].y = s_state | SHEXP_CLUSTER_UNCHANGED;
            atomicAdd(shexp_stats[6], 1u);
        }
    }
    // Receivers in the cluster (its head's z).
    s_k[tid] = valid;
    barrier();
    for (uint h = 32u; h > 0u; h >>= 1) {
        if (tid < h) s_k[tid] += s_k[tid + h];
        barrier();
    }
    if (tid == 0u) cluster_heads[c].z = s_k[0];
}
