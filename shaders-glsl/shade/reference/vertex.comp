#version 460
#extension GL_GOOGLE_include_directive : require
// Reference per world-space vertex (two-sided, as target_vertex.glsl); the raster pass interpolates.
#include "integrate.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 3) readonly buffer WorldVertices { Vertex world[]; };
layout(std430, binding = 4) writeonly buffer VertexRadiance { vec4 vertex_radiance[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= frame.vertex_count) return;
    Vertex v = world[i];
    vec3 n = v.normal.xyz;
    vec3 result = vec3(0.0);
    if (!(dot(n, n) > 0.0)) {
        store_fixed(i, result);
    } else {
        ShadePoint sp;
        sp.position = v.position.xyz;
        g_coordinate_scale = max_abs(v.position.xyz);
        sp.view = normalize(frame.eye.xyz - v.position.xyz);
        n = normalize(n);
        // As target_vertex.glsl: the vertex normal is both normals.
        shading_normals(n, n, sp.view, sp.normal, sp.geometric);
        sp.material = materials[uint(v.material)];
        result = accumulate(i, sp);
    }
    vertex_radiance[i] = vec4(result, 1.0);
}
