#version 460
#extension GL_GOOGLE_include_directive : require
// Object space → world space for every vertex: linear blend skinning by the bone matrices (identity for
// rigid vertices), then the instance transform.
#include "../common/scene.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Vertices { Vertex vertices[]; };
layout(std430, binding = 1) readonly buffer Objects { Object objects[]; };
layout(std430, binding = 2) writeonly buffer WorldVertices { Vertex world[]; };
layout(std430, binding = 3) readonly buffer Bones { mat4 bones[]; };
#include "../common/skinning.glsl"
layout(std430, binding = 4) readonly buffer VertexSkins { VertexSkin skins[]; };
layout(push_constant) uniform Push {
    uint vertex_count;
    uint bone_count;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.vertex_count) return;
    Vertex v = vertices[i];
    Object o = objects[uint(v.instance)];
    VertexSkin s = skins[i];
    mat4 b = skin_matrix(s.joints, s.weights, pc.bone_count);
    vec3 p = (o.model * (b * vec4(v.position.xyz, 1.0))).xyz;
    vec3 n = mat3(o.normal_matrix) * (skin_cofactor(mat3(b)) * v.normal.xyz);
    float len = length(n);
    n = len > 0.0 ? n / len : vec3(0.0, 1.0, 0.0);
    world[i] = Vertex(p, v.instance, n, v.material);
}
