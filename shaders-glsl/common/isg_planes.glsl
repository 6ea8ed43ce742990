// Plane blockers in the ISG patch grid (ours; the paper has spheres only). f32 twin of
// engine::passes::shade::isg::cpu::mark_planes.
//
// For the receiver p (set once per shading point by isg_planes_begin) and one lobe's grid:
// - a half-space marks the patches whose centre lies below its plane, the cap of half-angle π/2
//   around −m (isg_mark_cap: exact per row, like a sphere's cap);
// - a rectangle marks the patches whose centre direction hits the plate: the intersection of the four
//   caps of half-angle π/2 around its edge normals (planes.glsl), row by row the AND of four arcs.
// The self-shadowing rule of planes.glsl applies (a receiver on the plane is not shadowed by it).
//
// With ISG_PLANES, the includer defines ISG_PLANE_COUNT (a uint expression) and ISG_PLANE(i) (a
// BlockerPlane); without it, no-op stubs.
#ifndef ISG_PLANES_GLSL
#define ISG_PLANES_GLSL

#ifndef ISG_PLANES
void isg_planes_begin(vec3 p) {}
bool isg_planes_present() {
    return false;
}
bool isg_planes_mark(IsgGrid g) {
    return false;
}
#else
#include "planes.glsl"
#include "spheres.glsl"

vec3 g_isg_planes_p = vec3(0.0);
// Whether any plane can shadow the current receiver (set by isg_planes_begin).
bool g_isg_planes_any = false;

void isg_planes_begin(vec3 p) {
    g_isg_planes_p = p;
    g_isg_planes_any = false;
    for (uint k = 0u; k < ISG_PLANE_COUNT; ++k) {
        if (plane_blocks_receiver(ISG_PLANE(k), p)) g_isg_planes_any = true;
    }
}

bool isg_planes_present() {
    return g_isg_planes_any;
}

// Marks in isg_mask the patches of g whose centre direction from the receiver is blocked by a plane;
// whether any patch was marked by a rectangle or a half-space's cap could reach the grid.
bool isg_planes_mark(IsgGrid g) {
    if (!g_isg_planes_any) return false;
    vec3 p = g_isg_planes_p;
    bool marked = false;
    for (uint k = 0u; k < ISG_PLANE_COUNT; ++k) {
        BlockerPlane pl = ISG_PLANE(k);
        if (!plane_blocks_receiver(pl, p)) continue;
        if (!plane_is_rectangle(pl)) {
            vec3 down = -pl.plane.xyz;
            if (spheres_angle_between(g.z, down) > g.cone + ISG_HALF_PI) continue;
            isg_mark_cap(g, down, ISG_HALF_PI);
            marked = true;
            continue;
        }
        // The plate's bounding sphere against the cone holding the grid (u ⟂ v: |u + v|² = |u|² + |v|²).
        vec4 bound = vec4(pl.center.xyz, length(pl.half_u.xyz + pl.half_v.xyz));
        if (!cone_intersects_sphere(p, g.z, g.cone, bound)) continue;
        vec3 e[4];
        plane_edge_normals(pl, p, e);
        vec4 c0 = isg_cap_coords(g, e[0]);
        vec4 c1 = isg_cap_coords(g, e[1]);
        vec4 c2 = isg_cap_coords(g, e[2]);
        vec4 c3 = isg_cap_coords(g, e[3]);
        // Only rows within π/2 of every edge normal's θ can hold a marked centre.
        float t_lo = max(max(c0.w, c1.w), max(c2.w, c3.w)) - ISG_HALF_PI;
        float t_hi = min(min(c0.w, c1.w), min(c2.w, c3.w)) + ISG_HALF_PI;
        float last = float(g.side - 1);
        int i_lo = int(clamp(ceil((t_lo - g.lo) / g.delta - 0.5), 0.0, last + 1.0));
        int i_hi = int(clamp(floor((t_hi - g.lo) / g.delta - 0.5), -1.0, last));
        for (int i = i_lo; i <= i_hi; ++i) {
            uint bits = isg_cap_row_bits(g, i, c0.x, c0.y, c0.z, 0.0);
            if (bits == 0u) continue;
            bits &= isg_cap_row_bits(g, i, c1.x, c1.y, c1.z, 0.0);
            bits &= isg_cap_row_bits(g, i, c2.x, c2.y, c2.z, 0.0);
            bits &= isg_cap_row_bits(g, i, c3.x, c3.y, c3.z, 0.0);
            isg_mask[i] |= bits;
            if (bits != 0u) marked = true;
        }
    }
    return marked;
}
#endif // ISG_PLANES
#endif // ISG_PLANES_GLSL
