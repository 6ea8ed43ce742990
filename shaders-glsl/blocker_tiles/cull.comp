#version 460
#extension GL_GOOGLE_include_directive : require
// Blocker tiles: for each 16 × 16-pixel tile of the G-buffer, the start list of the per-pixel BVH
// traversals of `isg`, `lobes` and `shexp` (common/bvh.glsl, BVH_TILE_NODE): a cut of the blocker BVH, in
// depth-first left-first order, that drops the nodes no receiver of the tile can be shadowed by and stops
// above the nodes some receiver might take whole. f64 twin: engine::passes::shade::tiles::cpu::tile_list.
//
// Why the traversals then give the same answer as from the root:
// - Culled: a node lying wholly below the tangent plane of every receiver of the tile. Every technique
//   applies SHEXP §6.2's rules to the spheres it visits (spheres.glsl blocker_for_receiver), which drop a
//   sphere with (c − p)·n ≤ −r, and every sphere under the node lies below that plane too (a child lies
//   inside its parent: blocker_bvh/refit.comp). The node's whole subtree contributes nothing at any pixel.
// - Opened (its children listed instead): an internal node that no receiver of the tile can take whole:
//   every technique takes a node whole only when it subtends less than a half-angle T from the receiver
//   (isg's patch-width threshold, lobes' cell width, shexp's θ_max; the technique passes sin T), or when
//   its stack is full. A pixel's own traversal would open it too (or drop it by a cone test, and then drop
//   its children by the same test, as they lie inside it), so it visits the same nodes below it.
// - Listed: every other node, as the traversal's start. A full list falls back to the root alone
//   (the traversal from the root: the same image).
// Receivers enter through bounds: the bounding sphere (c_t, r_t) of the tile's positions and the cone
// (axis a, half-angle β) of its shading normals. For a node (c, R), d = c − c_t:
//   max over the tile of (c − p)·n ≤ |d| cos(max(∠(d, a) − β, 0)) + r_t   (cull when that is ≤ −R),
//   max over the tile of |c − p|  ≤ |d| + r_t                               (open when R ≥ sin T of that),
//   min over the tile of |c − p|  ≥ |d| − r_t          (tile_lod: listed whole when R < sin θ_lod of that;
//                                                        reach: culled when that minus R is past the reach).
// The level of detail is the one approximation here (option tile_lod, off by default): it changes the image.
layout(local_size_x = 16, local_size_y = 16) in;
#include "../common/bvh.glsl"

layout(binding = 0, rgba32f) uniform readonly image2D gbuf_position;
layout(binding = 1, rgba32f) uniform readonly image2D gbuf_normal;
layout(std430, binding = 2) readonly buffer BvhNodes { BvhNode bvh_nodes[]; };
// tile_nodes[0] = the stride S of a tile's record; tile t's record at 1 + t S: its list length, then up to
// S − 1 node indices.
layout(std430, binding = 3) buffer TileNodes { uint tile_nodes[]; };
// Counters since the last reset: tiles with receivers, Σ list lengths, longest list, tiles that fell back
// to the root, Σ nodes tested by this pass.
layout(std430, binding = 4) buffer TileStats { uint tile_stats[]; };
layout(push_constant) uniform TilePush {
    uint sphere_count;
    float sin_take_whole;  // sin T (1 when T ≥ π/2)
    uint stride;           // S: capacity + 1
    uint width;
    uint height;
    float sin_lod;         // sin θ_lod of option tile_lod (0: off)
    float reach;           // option reach (common/bvh.glsl; 0: off)
} pc;

const uint TILE = 16u;
// A list entry's "take whole" mark (BVH_TILE_WHOLE in common/bvh.glsl).
const uint BVH_TILE_WHOLE_BIT = 0x80000000u;
const uint TILE_PIXELS = TILE * TILE;
const float TILE_PI = 3.14159265358979;

shared vec3 s_lo[TILE_PIXELS];
shared vec3 s_hi[TILE_PIXELS];
shared vec3 s_n[TILE_PIXELS];
shared float s_cos[TILE_PIXELS];

void main() {
    uint l = gl_LocalInvocationIndex;
    uvec2 px = gl_GlobalInvocationID.xy;
    uint tiles_x = (pc.width + TILE - 1u) / TILE;
    uint tile = gl_WorkGroupID.y * tiles_x + gl_WorkGroupID.x;
    uint base = 1u + tile * pc.stride;
    bool valid = false;
    vec3 p = vec3(0.0);
    vec3 n = vec3(0.0);
    if (px.x < pc.width && px.y < pc.height) {
        vec4 pw = imageLoad(gbuf_position, ivec2(px));
        valid = pw.w >= 0.5;
        p = pw.xyz;
        n = imageLoad(gbuf_normal, ivec2(px)).xyz;
    }
    s_lo[l] = valid ? p : vec3(3.0e38);
    s_hi[l] = valid ? p : vec3(-3.0e38);
    s_n[l] = valid ? n : vec3(0.0);
    // Position bounds and the normals' sum.
    for (uint s = TILE_PIXELS / 2u; s > 0u; s >>= 1u) {
        barrier();
        if (l < s) {
            s_lo[l] = min(s_lo[l], s_lo[l + s]);
            s_hi[l] = max(s_hi[l], s_hi[l + s]);
            s_n[l] += s_n[l + s];
        }
    }
    barrier();
    vec3 sum = s_n[0];
    float len = length(sum);
    vec3 axis = len > 1e-6 ? sum / len : vec3(0.0, 0.0, 1.0);
    bool spread = !(len > 1e-6);
    // The normals' cone: the smallest cosine to the axis.
    s_cos[l] = valid ? dot(n, axis) : 1.0;
    for (uint s = TILE_PIXELS / 2u; s > 0u; s >>= 1u) {
        barrier();
        if (l < s) s_cos[l] = min(s_cos[l], s_cos[l + s]);
    }
    barrier();
    if (l != 0u) return;
    vec3 lo = s_lo[0];
    vec3 hi = s_hi[0];
    if (lo.x > hi.x || pc.sphere_count == 0u) {
        tile_nodes[base] = 0u;  // no receiver (or no blocker): nothing to traverse
        return;
    }
    vec3 ct = 0.5 * (lo + hi);
    // Rounding margins: the radius a little over the half diagonal, the cone a little wider.
    float rt = length(hi - lo) * 0.5 * (1.0 + 1e-5) + 1e-6 * (abs(ct.x) + abs(ct.y) + abs(ct.z));
    float beta = spread ? TILE_PI : min(acos(clamp(s_cos[0], -1.0, 1.0)) + 1e-3, TILE_PI);
    uint capacity = pc.stride - 1u;
    uint count = 0u;
    uint tested = 0u;
    bool full = false;
    uint stack[64];
    uint size = 1u;
    stack[0] = 0u;
    while (size > 0u) {
        size -= 1u;
        uint v = stack[size];
        tested += 1u;
        BvhNode nd = bvh_nodes[v];
        vec3 d = nd.center - ct;
        float dl = length(d);
        float r = nd.radius;
        // Cull: below every receiver's tangent plane (with a relative margin for rounding).
        float ang = dl > 0.0 ? acos(clamp(dot(d, axis) / dl, -1.0, 1.0)) : 0.0;
        float reach = dl * cos(min(max(ang - beta, 0.0), TILE_PI)) + rt;
        if (reach + r < -1e-4 * (dl + rt + r)) continue;
        // Bounded reach (option reach, an approximation): beyond it from every receiver of the tile.
        if (pc.reach > 0.0 && dl - rt - r >= pc.reach * (1.0 + 1e-4)) continue;
        // Level of detail (tile_lod > 0, an approximation): a node subtending less than θ_lod from every receiver
        // of the tile is listed marked whole, and every pixel takes it as one blocker.
        if (!bvh_is_leaf(nd) && dl > rt && r < pc.sin_lod * (dl - rt)) {
            if (count >= capacity) {
                full = true;
                break;
            }
            tile_nodes[base + 1u + count] = v | BVH_TILE_WHOLE_BIT;
            count += 1u;
            continue;
        }
        // Open: no receiver could take it whole (it subtends at least T from every one).
        bool open = !bvh_is_leaf(nd) && r >= pc.sin_take_whole * (dl + rt) * (1.0 + 1e-3) && size + 2u <= 64u;
        if (open) {
            stack[size] = nd.right;
            stack[size + 1u] = nd.left;
            size += 2u;
            continue;
        }
        if (count >= capacity) {
            full = true;
            break;
        }
        tile_nodes[base + 1u + count] = v;
        count += 1u;
    }
    if (full) {
        tile_nodes[base + 1u] = 0u;  // the root alone: every pixel traverses the whole BVH
        count = 1u;
        atomicAdd(tile_stats[3], 1u);
    }
    tile_nodes[base] = count;
    atomicAdd(tile_stats[0], 1u);
    atomicAdd(tile_stats[1], count);
    atomicMax(tile_stats[2], count);
    atomicAdd(tile_stats[4], tested);
}
