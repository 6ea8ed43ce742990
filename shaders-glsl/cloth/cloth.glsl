// The cloth simulation's push constants and collision (engine::passes::cloth; CPU twin:
// engine::scene::cloth::ClothSim). Include after declaring the buffers a kernel uses; kernels that
// collide declare `Spheres` first and define CLOTH_COLLIDE.
#ifndef CLOTH_GLSL
#define CLOTH_GLSL

// Twin: engine::passes::cloth::ClothPush.
layout(push_constant) uniform ClothPush {
    uint columns;
    uint rows;
    uint collider_count;  // world blocker spheres 0 .. collider_count − 1 are colliders
    uint vertex_base;     // the cloth's first vertex in the scene's vertex buffers
    float dt;             // substep (s)
    float keep;           // velocity kept per substep: max(0, 1 − damping·dt)
    float relaxation;     // ω of the averaged Jacobi step
    float thickness;      // collision margin (m)
    vec3 gravity;
    float ground;         // ground height (when has_ground is 1)
    vec3 alpha;           // XPBD α̃ = compliance / dt²: structural, shear, bending
    float has_ground;
    float friction;
    uint sphere_first;    // the first generated blocker sphere
    uint sphere_patch;    // quads per side of one generated sphere's patch
    uint emit_spheres;    // 0: generated spheres get radius 0 (the technique reads thin shells)
} pc;

#ifdef CLOTH_COLLIDE
// Push p out of the spheres grown by the thickness (in order), then above the ground; `contact` and the
// normal of the last collider that moved it. Twin: ClothSim::collide.
vec3 cloth_collide(vec3 p, out vec3 normal, out bool contact) {
    contact = false;
    normal = vec3(0.0, 1.0, 0.0);
    for (uint s = 0u; s < pc.collider_count; ++s) {
        vec4 sp = spheres[s];
        vec3 d = p - sp.xyz;
        float dist = length(d);
        float reach = sp.w + pc.thickness;
        if (dist < reach) {
            vec3 n = dist > 1e-12 ? d / dist : vec3(0.0, 1.0, 0.0);
            p = sp.xyz + n * reach;
            normal = n;
            contact = true;
        }
    }
    if (pc.has_ground > 0.5) {
        float floor_y = pc.ground + pc.thickness;
        if (p.y < floor_y) {
            p.y = floor_y;
            normal = vec3(0.0, 1.0, 0.0);
            contact = true;
        }
    }
    return p;
}
#endif

#endif
