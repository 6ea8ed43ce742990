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
    // Two-sided, as in the G-buffer pass; a vertex has no face, so its normal is also the geometric
    // one (shading_normals then only chooses the side).
    shading_normals(v.normal.xyz, v.normal.xyz, sp.view, sp.normal, sp.geometric);
    sp.material = materials[uint(v.material)];
    vec3 result = shade_point(sp);
    if (any(isnan(result)) || any(isinf(result))) result = vec3(0.0);
    vertex_radiance[i] = vec4(result, 1.0);
}
