#version 460
#extension GL_GOOGLE_include_directive : require
// World-space blocker spheres for this frame (engine::passes::blocker_spheres): rest centre skinned by
// the sphere's bone binding (identity when rigid), then the instance transform; radius kept, scaled by
// the instance's largest axis scale (SHEXP Sec. 6.2 "Animation").
#include "../common/scene.glsl"
layout(local_size_x = 64) in;
struct BlockerSphere {
    vec4 sphere;   // rest centre (object space), radius
    uvec4 joints;
    vec4 weights;  // sum 0: rigid
    uint object;   // the instance the sphere belongs to
    uint pad0;
    uint pad1;
    uint pad2;
};
layout(std430, binding = 0) readonly buffer BlockerSpheres { BlockerSphere rest[]; };
layout(std430, binding = 1) readonly buffer Objects { Object objects[]; };
layout(std430, binding = 2) readonly buffer Bones { mat4 bones[]; };
#include "../common/skinning.glsl"
layout(std430, binding = 3) writeonly buffer Spheres { vec4 spheres[]; };
layout(push_constant) uniform Push {
    uint sphere_count;
    uint bone_count;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.sphere_count) return;
    BlockerSphere s = rest[i];
    mat4 model = objects[s.object].model;
    vec3 c = (model * (skin_matrix(s.joints, s.weights, pc.bone_count) * vec4(s.sphere.xyz, 1.0))).xyz;
    float scale = max(length(model[0].xyz), max(length(model[1].xyz), length(model[2].xyz)));
    spheres[i] = vec4(c, s.sphere.w * scale);
}
