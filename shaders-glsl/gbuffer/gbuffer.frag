#version 460
#extension GL_GOOGLE_include_directive : require
// G-buffer: world position (w = material + 1; 0 marks background), the shading normal facing the
// viewer (meshes are two-sided), interpolated per-vertex radiance, and the geometric normal facing
// the viewer (the side rays leave from; w = the index of the triangle's first vertex, as a float). Both normals come from common/shading.glsl: the side is the
// geometric normal's, and a shading normal that faces away from the viewer where the triangle faces
// it (silhouettes of smooth meshes) is bent back (shading normal adaptation) rather than flipped into
// the mesh.
#include "../common/scene.glsl"
#include "../common/shading.glsl"
layout(std430, binding = 1) readonly buffer FrameBuf { FrameData frame; };
layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) flat in float in_material;
layout(location = 3) in vec3 in_radiance;
layout(location = 4) flat in float in_vertex;
layout(location = 0) out vec4 gbuf_position;
layout(location = 1) out vec4 gbuf_normal;
layout(location = 2) out vec4 gbuf_vertex_radiance;
layout(location = 3) out vec4 gbuf_geometric;

void main() {
    vec3 n = in_normal;
    float len = length(n);
    n = len > 0.0 ? n / len : vec3(0.0, 1.0, 0.0);
    // The triangle's plane from the screen-space derivatives of the world position: within a 2×2
    // quad every lane (helpers included) evaluates the same triangle's interpolant, and a
    // perspective-correct interpolant of an affine function stays on the triangle's plane, so the
    // two differences span it. Degenerate (edge-on, zero-area): the shading normal stands in.
    vec3 g = cross(dFdx(in_position), dFdy(in_position));
    float glen = length(g);
    g = glen > 0.0 && !isinf(glen) ? g / glen : n;
    vec3 v = frame.eye.xyz - in_position;
    float vlen = length(v);
    v = vlen > 0.0 ? v / vlen : g;
    vec3 shading, geometric;
    shading_normals(n, g, v, shading, geometric);
    gbuf_position = vec4(in_position, in_material + 1.0);
    gbuf_normal = vec4(shading, 1.0);
    gbuf_vertex_radiance = vec4(in_radiance, 1.0);
    gbuf_geometric = vec4(geometric, in_vertex);
}
