// What every technique reads: frame constants, materials, the environment; and the shading point.
#ifndef SHADE_COMMON_GLSL
#define SHADE_COMMON_GLSL
#include "../common/scene.glsl"
#include "../common/envmap.glsl"
#include "../common/shading.glsl"

layout(std430, binding = 0) readonly buffer FrameBuf { FrameData frame; };
layout(std430, binding = 1) readonly buffer Materials { Material materials[]; };
layout(binding = 2) uniform sampler2D env_map;

// Built by target_pixel.glsl from the G-buffer (whose normals come from shading_normals) and by
// target_vertex.glsl through shading_normals, so every technique sees the same frame.
struct ShadePoint {
    vec3 position;
    vec3 normal;     // shading normal: unit, facing the viewer (adapted, common/shading.glsl)
    vec3 geometric;  // geometric normal: unit, facing the viewer; the side rays leave from
    vec3 view;       // unit, towards the viewer
    Material material;
};

vec3 environment_radiance(vec3 d) {
    return textureLod(env_map, envmap_uv(d), 0.0).rgb;
}

// Technique entry points include this file, define `vec3 shade_point(ShadePoint)` and then include
// target_pixel.glsl or target_vertex.glsl.
#endif
