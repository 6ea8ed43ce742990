#version 460
#extension GL_GOOGLE_include_directive : require
// G-buffer: world position (w = material + 1; 0 marks background), shading normal facing the
// viewer (meshes are two-sided), interpolated per-vertex radiance.
#include "../common/scene.glsl"
layout(std430, binding = 1) readonly buffer FrameBuf { FrameData frame; };
layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) flat in float in_material;
layout(location = 3) in vec3 in_radiance;
layout(location = 0) out vec4 gbuf_position;
layout(location = 1) out vec4 gbuf_normal;
layout(location = 2) out vec4 gbuf_vertex_radiance;

void main() {
    vec3 n = in_normal;
    float len = length(n);
    n = len > 0.0 ? n / len : vec3(0.0, 1.0, 0.0);
    if (dot(n, frame.eye.xyz - in_position) < 0.0) n = -n;
    gbuf_position = vec4(in_position, in_material + 1.0);
    gbuf_normal = vec4(n, 1.0);
    gbuf_vertex_radiance = vec4(in_radiance, 1.0);
}
