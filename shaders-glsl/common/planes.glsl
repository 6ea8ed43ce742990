// Plane blockers: half-spaces and rectangles (the ground, a table top, a wall) beside the spheres and
// thin shells. f32 twin of engine_blockers::plane (see its docs for the rules); the record is
// engine::resources::blockers::GpuBlockerPlane.
//
// - half-space (center.w = 0): the solid m·x < d. A receiver more than ε above the plane sees no
//   direction with m·ω < 0; on or below the plane it is not shadowed by it.
// - rectangle (center.w = 1): the two-sided plate center + s·half_u + t·half_v, |s|, |t| ≤ 1. A receiver
//   more than ε off its plane, on either side, does not see the directions whose rays hit the plate.
#ifndef PLANES_GLSL
#define PLANES_GLSL

struct BlockerPlane {
    vec4 plane;   // unit normal m, offset d of m·x = d
    vec4 center;  // rectangle centre; w: 1 rectangle, 0 half-space
    vec4 half_u;  // rectangle half side; w: the self-shadowing tolerance ε (world units)
    vec4 half_v;  // rectangle half side
};

bool plane_is_rectangle(BlockerPlane pl) {
    return pl.center.w > 0.5;
}

// Signed distance of p above the plane. Twin: BlockerPlane::height.
float plane_height(BlockerPlane pl, vec3 p) {
    return dot(pl.plane.xyz, p) - pl.plane.w;
}

// The self-shadowing rule: whether the plane can shadow a receiver at p. Twin: blocks_receiver.
bool plane_blocks_receiver(BlockerPlane pl, vec3 p) {
    float h = plane_height(pl, p);
    return plane_is_rectangle(pl) ? abs(h) > pl.half_u.w : h > pl.half_u.w;
}

// Distance along unit d from o to the plane blocker for a receiver at `receiver`, or -1 when the ray
// misses it within (0, t_max). Twin: BlockerPlane::hit.
float plane_hit(BlockerPlane pl, vec3 receiver, vec3 o, vec3 d, float t_max) {
    if (!plane_blocks_receiver(pl, receiver)) return -1.0;
    float md = dot(pl.plane.xyz, d);
    if (md == 0.0) return -1.0;
    float t = (pl.plane.w - dot(pl.plane.xyz, o)) / md;
    if (!(t > 0.0 && t < t_max)) return -1.0;
    if (!plane_is_rectangle(pl)) return md < 0.0 ? t : -1.0;
    vec3 q = o + t * d - pl.center.xyz;
    vec3 u = pl.half_u.xyz;
    vec3 v = pl.half_v.xyz;
    return (abs(dot(q, u)) <= dot(u, u) && abs(dot(q, v)) <= dot(v, v)) ? t : -1.0;
}

// The directions from p blocked by a rectangle as four half-spaces of directions: ω is blocked iff
// ω·e[k] ≥ 0 for every k (the cone from p over the plate). The caller checks plane_blocks_receiver.
// Twin: BlockerPlane::edge_normals.
void plane_edge_normals(BlockerPlane pl, vec3 p, out vec3 e[4]) {
    vec3 c = pl.center.xyz - p;
    vec3 u = pl.half_u.xyz;
    vec3 v = pl.half_v.xyz;
    vec3 a0 = c - u - v;
    vec3 a1 = c + u - v;
    vec3 a2 = c + u + v;
    vec3 a3 = c - u + v;
    // Corners counter-clockwise about m: from above a_k × a_{k+1} points out of the cone.
    float s = plane_height(pl, p) > 0.0 ? -1.0 : 1.0;
    e[0] = normalize(s * cross(a0, a1));
    e[1] = normalize(s * cross(a1, a2));
    e[2] = normalize(s * cross(a2, a3));
    e[3] = normalize(s * cross(a3, a0));
}

// ∫ (n·ω)⁺ dω over the directions through the convex polygon a[0..3] (vertices relative to the viewpoint, in
// order): the polygon clipped to n·x ≥ 0 (its edges are great-circle arcs, so the clip is linear), then
// Lambert's formula ½ |Σ_e Θ_e n·u_e| (Θ_e the edge's angle, u_e its plane's unit normal): exact.
// Twin: plane::polygon_projected_solid_angle.
float plane_polygon_projected_solid_angle(vec3 a[4], vec3 n) {
    vec3 poly[5];
    int count = 0;
    for (int k = 0; k < 4; ++k) {
        vec3 u = a[k];
        vec3 w = a[(k + 1) & 3];
        float du = dot(n, u);
        float dw = dot(n, w);
        if (du >= 0.0) {
            poly[count] = u;
            count += 1;
        }
        if ((du >= 0.0) != (dw >= 0.0) && count < 5) {
            poly[count] = u + (w - u) * (du / (du - dw));
            count += 1;
        }
    }
    if (count < 3) return 0.0;
    float sum = 0.0;
    for (int k = 0; k < count; ++k) {
        vec3 u = poly[k];
        vec3 w = poly[k + 1 < count ? k + 1 : 0];
        vec3 x = cross(u, w);
        float lx = length(x);
        if (lx > 0.0) sum += atan(lx, dot(u, w)) * dot(n, x) / lx;
    }
    return min(0.5 * abs(sum), 3.14159265358979);
}

// The cosine-weighted solid angle of the directions from p (unit normal n) the blocker hides: 0 when the
// self-shadowing rule spares p, π(1 − n·m)/2 for a half-space, Lambert's formula over the clipped plate for
// a rectangle. Twin: BlockerPlane::projected_solid_angle.
float plane_projected_solid_angle(BlockerPlane pl, vec3 p, vec3 n) {
    if (!plane_blocks_receiver(pl, p)) return 0.0;
    if (!plane_is_rectangle(pl)) return 0.5 * 3.14159265358979 * (1.0 - clamp(dot(n, pl.plane.xyz), -1.0, 1.0));
    vec3 c = pl.center.xyz - p;
    vec3 u = pl.half_u.xyz;
    vec3 v = pl.half_v.xyz;
    vec3 a[4] = vec3[4](c - u - v, c + u - v, c + u + v, c - u + v);
    return plane_polygon_projected_solid_angle(a, n);
}

#endif // PLANES_GLSL
