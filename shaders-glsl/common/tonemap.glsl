// Linear radiance → display value: exposure, ACES filmic fit (Narkowicz 2015), sRGB encoding.
// f64 twin: engine/math/src/tonemap.rs (tests/tests/math_gpu_tonemap.rs).
#ifndef TONEMAP_GLSL
#define TONEMAP_GLSL

// The fit reaches 1 (white) at x ≈ 7.25 and stays there, but its x² overflows f32 from x ≈ 1.8e19: inf / inf is
// NaN, which the clamp turned into black (a light of radiance 1e38 rendered black). Everything above this is
// white before the fit, +inf included; NaN is black, as before.
const float TONEMAP_WHITE = 16.0;

vec3 aces(vec3 x) {
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

vec3 srgb_encode(vec3 c) {
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}

// `radiance` × `exposure` to a display value in [0, 1] per channel.
vec3 tonemap(vec3 radiance, float exposure) {
    vec3 c = radiance * exposure;
    // NaN first: clamp() of a NaN is undefined.
    c = mix(c, vec3(0.0), isnan(c));
    return srgb_encode(aces(clamp(c, vec3(0.0), vec3(TONEMAP_WHITE))));
}

#endif
