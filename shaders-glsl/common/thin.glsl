// Thin shells (ISG Sec. 5, cloth): the world-space triangles of meshes marked thin, grouped in clusters
// with a bounding sphere (written every frame by the thin_shells pass; host twins in
// engine/src/passes/thin_shells.rs, checked by tests/tests/struct_layouts.rs), and the self-shadowing
// rule every consumer applies (f64 twin: engine::passes::shade::isg::thin::blocks_receiver).
#ifndef THIN_GLSL
#define THIN_GLSL

struct ThinTriangle {
    vec4 v0;  // world space, w = 1
    vec4 v1;
    vec4 v2;
};

struct ThinCluster {
    vec4 bound;  // bounding sphere of its triangles (centre, radius), as spheres.glsl takes spheres
    uint first;  // first triangle
    uint count;  // triangle count
    uint pad0;
    uint pad1;
};

// A triangle whose plane passes within THIN_PLANE_EPS × (its longest edge) of the receiver cannot block
// it: the receiver's own triangle, its coplanar neighbours, and triangles seen edge-on (which subtend no
// solid angle). Degenerate (zero-area) triangles never block.
const float THIN_PLANE_EPS = 1e-3;

// Receiver-relative vertices a, b, c. Returns false when the triangle is ignored; otherwise `orient` is
// the sign of det(a, b, c) (the side of its plane the receiver is on).
bool thin_blocks_receiver(vec3 a, vec3 b, vec3 c, out float orient) {
    vec3 e1 = b - a;
    vec3 e2 = c - a;
    vec3 nrm = cross(e1, e2);
    float len2 = max(dot(e1, e1), max(dot(e2, e2), dot(c - b, c - b)));
    float area2 = length(nrm);
    orient = 0.0;
    if (!(area2 > 1e-6 * len2)) return false;  // thinner than 1e-6 of its longest edge (f32 noise)
    // det(a, b, c) = (b − a) × (c − a) · a: the plane's signed distance from the receiver times |nrm|.
    float det = dot(nrm, a);
    if (!(abs(det) > THIN_PLANE_EPS * sqrt(len2) * area2)) return false;
    orient = det > 0.0 ? 1.0 : -1.0;
    return true;
}

#endif // THIN_GLSL
