#version 460
#extension GL_GOOGLE_include_directive : require
// Linear radiance → display: exposure, ACES filmic fit (Narkowicz 2015), sRGB encoding (common/tonemap.glsl).
#include "../common/scene.glsl"
#include "../common/tonemap.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer FrameBuf { FrameData frame; };
layout(binding = 1, rgba32f) uniform readonly image2D radiance;
layout(binding = 2, rgba8) uniform writeonly image2D ldr;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(px), frame.size.xy))) return;
    imageStore(ldr, px, vec4(tonemap(imageLoad(radiance, px).rgb, frame.exposure), 1.0));
}
