// The scene's spherical lights, shared by every technique (Rust twin:
// engine::resources::lights::{GpuLightsHeader, GpuSphereLight}, one buffer for the whole scene).
#ifndef SHADE_LIGHTS_GLSL
#define SHADE_LIGHTS_GLSL

struct SphereLight {
    vec4 center_radius;  // world-space centre, radius
    vec4 radiance;       // linear RGB, w = 0
};
layout(std430, binding = 20) readonly buffer Lights {
    uint light_count;
    SphereLight lights[];  // at least one record (zero when light_count = 0)
};

#endif
