// The scene's spherical lights, shared by every technique (Rust twin:
// engine::resources::lights::{GpuLightsHeader, GpuSphereLight}, one buffer for the whole scene).
// Unshadowed light from one sphere (the closed forms of common/sphere_light.glsl, f64 twins in
// engine::math::sphere_light): the diffuse term ρ/π · L · ∫_cap (n·ω)⁺ dω exactly, the specular term
// Σ_j w_j · L · ∫_cap G_j over the material's specular SG lobes (common/brdf.glsl). Techniques that
// shadow scale it by their visibility of the light.
#ifndef SHADE_LIGHTS_GLSL
#define SHADE_LIGHTS_GLSL
#include "common.glsl"
#include "../common/brdf.glsl"
#include "../common/sphere_light.glsl"

struct SphereLight {
    vec3 center;  // world space
    float radius;
    vec3 radiance;  // linear RGB
    float pad0;
};
layout(std430, binding = 20) readonly buffer Lights {
    uint light_count;
    SphereLight lights[];  // at least one record (zero when light_count = 0)
};


// The cap light j subtends from p (false: p is inside the light, which then fills every direction).
bool light_cap(uint j, vec3 p, out vec3 axis, out float sin_alpha, out float cos_alpha) {
    return cap_from_sphere(p, lights[j].center, lights[j].radius, axis, sin_alpha, cos_alpha);
}

// Unshadowed radiance from light j at sp, given the material's specular lobes at sp and the cap.
vec3 light_unshadowed(ShadePoint sp, uint j, SpecLobe lobes[BRDF_MAX_LOBES], int count, bool outside, vec3 axis,
                      float sin_alpha, float cos_alpha) {
    float e = outside ? cap_clamped_cosine(dot(sp.normal, axis), sin_alpha, cos_alpha) : PI;
    vec3 result = sp.material.diffuse.rgb / PI * e;
    vec3 spec = vec3(0.0);
    for (int k = 0; k < count; ++k) {
        if (all(equal(lobes[k].weight, vec3(0.0)))) continue;
        float g = outside ? cap_sg_integral(lobes[k].axis, lobes[k].lambda, axis, sin_alpha, cos_alpha)
                          : sg_integral(lobes[k].lambda, 1.0);
        spec += lobes[k].weight * g;
    }
    // The least-squares lobe amplitudes may be negative (Ashikhmin-Shirley): clamp the sum, as the
    // environment's specular term does.
    return lights[j].radiance * (result + max(spec, vec3(0.0)));
}

// Σ over every light of its unshadowed radiance (technique `none`).
vec3 lights_unshadowed(ShadePoint sp) {
    if (light_count == 0u) return vec3(0.0);
    SpecLobe lobes[BRDF_MAX_LOBES];
    int count = brdf_specular_lobes(sp.material, sp.normal, sp.view, lobes);
    vec3 sum = vec3(0.0);
    for (uint j = 0u; j < light_count; ++j) {
        vec3 axis;
        float sa, ca;
        bool outside = light_cap(j, sp.position, axis, sa, ca);
        sum += light_unshadowed(sp, j, lobes, count, outside, axis, sa, ca);
    }
    return sum;
}

#endif
