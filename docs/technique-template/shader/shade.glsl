// Technique `template`: ρ/π E(n) from the shared irradiance grid, times a gain.
#include "../common.glsl"
#include "../prefiltered.glsl"
layout(binding = 8) uniform sampler2D irradiance_map;
layout(push_constant) uniform Push { float gain; } push;

vec3 shade_point(ShadePoint sp) {
    return push.gain * sp.material.diffuse.rgb / PI * irradiance_lookup(irradiance_map, sp.normal);
}
