#version 460
#extension GL_GOOGLE_include_directive : require
// Reference per G-buffer pixel: accumulates into AccumMean/AccumM2 and writes the running mean.
#include "integrate.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 3, rgba32f) uniform readonly image2D gbuf_position;
layout(binding = 4, rgba32f) uniform readonly image2D gbuf_normal;
layout(binding = 5, rgba32f) uniform writeonly image2D radiance;
layout(binding = 18, rgba32f) uniform readonly image2D gbuf_geometric;
layout(std430, binding = 19) readonly buffer WorldVertices { Vertex world[]; };

// As in target_pixel.glsl.
vec3 camera_ray(ivec2 px) {
    vec2 ndc = (vec2(px) + 0.5) / vec2(frame.size.xy) * 2.0 - 1.0;
    return normalize(frame.forward.xyz + ndc.x * frame.tan_half_fov_x * frame.right.xyz - ndc.y * frame.tan_half_fov_y * frame.up.xyz);
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(px), frame.size.xy))) return;
    uint item = uint(px.y) * frame.size.x + uint(px.x);
    vec4 p = imageLoad(gbuf_position, px);
    vec3 nrm = imageLoad(gbuf_normal, px).xyz;
    vec3 result;
    if (p.w < 0.5 || !(dot(nrm, nrm) > 0.0)) {
        // Background (the same bilinear environment lookup as every technique).
        result = environment_radiance(camera_ray(px));
        store_fixed(item, result);
    } else {
        ShadePoint sp;
        sp.position = p.xyz;
        sp.normal = normalize(nrm);
        vec4 geo = imageLoad(gbuf_geometric, px);
        sp.geometric = geo.xyz;
        // The G-buffer interpolated the position from its triangle's vertices (w: the first one's index).
        uint v0 = uint(max(geo.w, 0.0));
        g_coordinate_scale = max(max_abs(p.xyz), v0 < uint(world.length()) ? max_abs(world[v0].position) : 0.0);
        sp.view = normalize(frame.eye.xyz - p.xyz);
        sp.material = materials[uint(p.w - 0.5)];
        result = accumulate(item, sp);
    }
    imageStore(radiance, px, vec4(result, 1.0));
}
