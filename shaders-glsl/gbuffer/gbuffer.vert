#version 460
#extension GL_GOOGLE_include_directive : require
// Vertex pulling from the world-space vertex buffer; also interpolates per-vertex radiance and passes the
// triangle's first vertex index (exact as a float up to 2^24 vertices).
#include "../common/scene.glsl"
layout(std430, binding = 0) readonly buffer WorldVertices { Vertex world[]; };
layout(std430, binding = 1) readonly buffer FrameBuf { FrameData frame; };
layout(std430, binding = 2) readonly buffer VertexRadiance { vec4 vertex_radiance[]; };
layout(location = 0) out vec3 out_position;
layout(location = 1) out vec3 out_normal;
layout(location = 2) flat out float out_material;
layout(location = 3) out vec3 out_radiance;
// The vertex's index: flat, so a fragment gets its triangle's first (provoking) vertex.
layout(location = 4) flat out float out_vertex;

void main() {
    Vertex v = world[gl_VertexIndex];
    vec3 d = v.position.xyz - frame.eye.xyz;
    float x = dot(d, frame.right.xyz) / frame.tan_half_fov_x;
    float y = dot(d, frame.up.xyz) / frame.tan_half_fov_y;
    float z = dot(d, frame.forward.xyz);
    float n = frame.near, f = frame.far;
    // Vulkan clip space: y down, depth (z − n) f / ((f − n) z) in [0, 1].
    gl_Position = vec4(x, -y, (z - n) * f / (f - n), z);
    out_position = v.position.xyz;
    out_normal = v.normal.xyz;
    out_material = v.material;
    out_radiance = vertex_radiance[gl_VertexIndex].rgb;
    out_vertex = float(gl_VertexIndex);
}
