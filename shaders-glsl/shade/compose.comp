#version 460
#extension GL_GOOGLE_include_directive : require
// Per-vertex mode: covered pixels take the interpolated vertex radiance, background the environment.
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 3, rgba32f) uniform readonly image2D gbuf_position;
layout(binding = 4, rgba32f) uniform readonly image2D gbuf_vertex_radiance;
layout(binding = 5, rgba32f) uniform writeonly image2D radiance;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(px), frame.size.xy))) return;
    vec3 result;
    if (imageLoad(gbuf_position, px).w < 0.5) {
        vec2 ndc = (vec2(px) + 0.5) / vec2(frame.size.xy) * 2.0 - 1.0;
        vec3 d = frame.forward.xyz + ndc.x * frame.tan_half_fov_x * frame.right.xyz - ndc.y * frame.tan_half_fov_y * frame.up.xyz;
        result = environment_radiance(d);
    } else {
        result = imageLoad(gbuf_vertex_radiance, px).rgb;
    }
    if (any(isnan(result)) || any(isinf(result))) result = vec3(0.0);
    imageStore(radiance, px, vec4(result, 1.0));
}
