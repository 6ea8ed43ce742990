// Technique `none`: unshadowed environment lighting.
// Diffuse: ρ_d/π · E(n) from the irradiance grid (exact clamped-cosine convolution, rows on the poles).
// Specular: the material's BRDF as J warped SGs (Blinn-Phong, Cook-Torrance: 1; Ashikhmin-Shirley: 7)
// against the SG-prefiltered environment (ISG Eq. 10); see ../prefiltered.glsl, ../../common/brdf.glsl.
// Spherical lights: each added unshadowed in closed form (../lights.glsl).
#include "../common.glsl"
#include "../prefiltered.glsl"
#include "../lights.glsl"
layout(binding = 8) uniform sampler2D irradiance_map;
layout(binding = 9) uniform sampler2D prefiltered_env;

vec3 shade_point(ShadePoint sp) {
    vec3 diffuse = sp.material.diffuse.rgb / PI * irradiance_lookup(irradiance_map, sp.normal);
    diffuse += lights_unshadowed(sp);
    vec3 ks = sp.material.specular.rgb;
    if (all(equal(ks, vec3(0.0)))) return diffuse;
    return diffuse + specular_prefiltered(prefiltered_env, sp.material, sp.normal, sp.view);
}
