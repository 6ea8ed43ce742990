// Per-vertex target: one invocation per world-space vertex; the raster pass interpolates.
layout(local_size_x = 64) in;
layout(std430, binding = 3) readonly buffer WorldVertices { Vertex world[]; };
layout(std430, binding = 4) writeonly buffer VertexRadiance { vec4 vertex_radiance[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= frame.vertex_count) return;
    Vertex v = world[i];
    ShadePoint sp;
    sp.position = v.position.xyz;
    sp.view = normalize(frame.eye.xyz - v.position.xyz);
    vec3 n = v.normal.xyz;
    // Two-sided, as in the G-buffer pass.
    sp.normal = dot(n, sp.view) < 0.0 ? -n : n;
    sp.material = materials[uint(v.material)];
    vec3 result = shade_point(sp);
    if (any(isnan(result)) || any(isinf(result))) result = vec3(0.0);
    vertex_radiance[i] = vec4(result, 1.0);
}
