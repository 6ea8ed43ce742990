#version 460
#extension GL_GOOGLE_include_directive : require
// Linear radiance → display: exposure, ACES filmic fit (Narkowicz 2015), sRGB encoding.
#include "../common/scene.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer FrameBuf { FrameData frame; };
layout(binding = 1, rgba32f) uniform readonly image2D radiance;
layout(binding = 2, rgba8) uniform writeonly image2D ldr;

vec3 aces(vec3 x) {
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

vec3 srgb_encode(vec3 c) {
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(px), frame.size.xy))) return;
    vec3 c = imageLoad(radiance, px).rgb * frame.exposure;
    if (any(isnan(c)) || any(isinf(c))) c = vec3(0.0);
    imageStore(ldr, px, vec4(srgb_encode(aces(max(c, vec3(0.0)))), 1.0));
}
