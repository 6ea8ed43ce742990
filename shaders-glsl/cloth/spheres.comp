#version 460
#extension GL_GOOGLE_include_directive : require
// Blocker spheres along the cloth, one per sphere_patch × sphere_patch quads: the bounding sphere of the
// patch's vertices (centre of their bounding box, radius of the farthest one plus the thickness), written
// after the scene's other spheres for the BVH build. Radius 0 when the technique reads thin shells (its
// triangles are then the cloth's blockers). Twin: engine::scene::cloth::patch_sphere.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer ClothX { vec4 x[]; };
layout(std430, binding = 1) writeonly buffer Spheres { vec4 spheres[]; };
#include "cloth.glsl"

void main() {
    uint s = gl_GlobalInvocationID.x;
    uint k = pc.sphere_patch;
    if (k == 0u) return;
    uint across = (pc.columns - 2u) / k + 1u;  // ceil((columns − 1) / k)
    uint down = (pc.rows - 2u) / k + 1u;
    if (s >= across * down) return;
    uint i0 = (s % across) * k;
    uint j0 = (s / across) * k;
    uint i1 = min(i0 + k, pc.columns - 1u);
    uint j1 = min(j0 + k, pc.rows - 1u);
    vec3 lo = vec3(3.0e38);
    vec3 hi = vec3(-3.0e38);
    for (uint j = j0; j <= j1; ++j) {
        for (uint i = i0; i <= i1; ++i) {
            vec3 p = x[j * pc.columns + i].xyz;
            lo = min(lo, p);
            hi = max(hi, p);
        }
    }
    vec3 c = 0.5 * (lo + hi);
    float r2 = 0.0;
    for (uint j = j0; j <= j1; ++j) {
        for (uint i = i0; i <= i1; ++i) {
            vec3 d = x[j * pc.columns + i].xyz - c;
            r2 = max(r2, dot(d, d));
        }
    }
    float r = sqrt(r2) + pc.thickness;
    spheres[pc.sphere_first + s] = vec4(c, pc.emit_spheres != 0u ? r : 0.0);
}
