// What every technique reads: frame constants, materials, the environment; and the shading point.
#ifndef SHADE_COMMON_GLSL
#define SHADE_COMMON_GLSL
#include "../common/scene.glsl"
#include "../common/envmap.glsl"

layout(std430, binding = 0) readonly buffer FrameBuf { FrameData frame; };
layout(std430, binding = 1) readonly buffer Materials { Material materials[]; };
layout(binding = 2) uniform sampler2D env_map;

struct ShadePoint {
    vec3 position;
    vec3 normal;   // unit, facing the viewer
    vec3 view;     // unit, towards the viewer
    Material material;
};

vec3 environment_radiance(vec3 d) {
    return textureLod(env_map, envmap_uv(d), 0.0).rgb;
}

// Technique entry points include this file, define `vec3 shade_point(ShadePoint)` and then include
// target_pixel.glsl or target_vertex.glsl.
#endif
