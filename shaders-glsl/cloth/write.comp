#version 460
#extension GL_GOOGLE_include_directive : require
// The cloth's world-space vertices for the G-buffer, the thin-shell pass and the shading: positions of
// the simulation, normals from central differences along the grid (one-sided at the borders), oriented
// as the rest grid's +Y; instance and material kept from the scene's vertex.
#include "../common/scene.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer ClothX { vec4 x[]; };
layout(std430, binding = 1) readonly buffer Vertices { Vertex vertices[]; };
layout(std430, binding = 2) writeonly buffer WorldVertices { Vertex world[]; };
#include "cloth.glsl"

vec3 at(int i, int j) {
    return x[uint(j) * pc.columns + uint(i)].xyz;
}

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= pc.columns * pc.rows) return;
    int i = int(k % pc.columns);
    int j = int(k / pc.columns);
    int last_i = int(pc.columns) - 1;
    int last_j = int(pc.rows) - 1;
    vec3 dx = at(min(i + 1, last_i), j) - at(max(i - 1, 0), j);
    vec3 dz = at(i, min(j + 1, last_j)) - at(i, max(j - 1, 0));
    vec3 n = cross(dz, dx);
    float len = length(n);
    n = len > 1e-20 ? n / len : vec3(0.0, 1.0, 0.0);
    Vertex v = vertices[pc.vertex_base + k];
    world[pc.vertex_base + k] = Vertex(x[k].xyz, v.instance, n, v.material);
}
