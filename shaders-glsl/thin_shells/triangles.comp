#version 460
#extension GL_GOOGLE_include_directive : require
// World-space thin-shell triangles and their clusters' bounding spheres for this frame
// (engine::passes::thin_shells): one invocation per cluster copies its triangles out of the skinned
// world vertices and bounds them (centre of the bounding box, radius of the farthest vertex, padded).
#include "../common/scene.glsl"
#include "../common/thin.glsl"
layout(local_size_x = 32) in;
layout(std430, binding = 0) readonly buffer WorldVertices { Vertex world[]; };
layout(std430, binding = 1) readonly buffer ThinIndices { uvec4 thin_indices[]; };
layout(std430, binding = 2) writeonly buffer ThinTriangles { ThinTriangle thin_triangles[]; };
layout(std430, binding = 3) buffer ThinClusters { ThinCluster thin_clusters[]; };
layout(push_constant) uniform Push {
    uint cluster_count;
} pc;

void main() {
    uint c = gl_GlobalInvocationID.x;
    if (c >= pc.cluster_count) return;
    uint first = thin_clusters[c].first;
    uint count = thin_clusters[c].count;
    if (count == 0u) {
        thin_clusters[c].bound = vec4(0.0);
        return;
    }
    vec3 lo = vec3(3.0e38);
    vec3 hi = vec3(-3.0e38);
    for (uint t = first; t < first + count; ++t) {
        uvec4 k = thin_indices[t];
        vec3 a = world[k.x].position.xyz;
        vec3 b = world[k.y].position.xyz;
        vec3 d = world[k.z].position.xyz;
        thin_triangles[t] = ThinTriangle(vec4(a, 1.0), vec4(b, 1.0), vec4(d, 1.0));
        lo = min(lo, min(a, min(b, d)));
        hi = max(hi, max(b, max(a, d)));
    }
    vec3 centre = 0.5 * (lo + hi);
    float r2 = 0.0;
    for (uint t = first; t < first + count; ++t) {
        uvec4 k = thin_indices[t];
        for (int v = 0; v < 3; ++v) {
            vec3 p = world[k[v]].position.xyz - centre;
            r2 = max(r2, dot(p, p));
        }
    }
    float r = sqrt(r2);
    // f32 rounding of the centre and the distances: pad so every vertex is inside.
    thin_clusters[c].bound = vec4(centre, r + 1e-5 * (r + length(centre)));
}
