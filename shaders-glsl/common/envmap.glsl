// Lat-long environment convention; twin of engine_math::envmap (Y up, row 0 = zenith,
// direction = (sin θ cos φ, cos θ, sin θ sin φ), θ = π v, φ = 2π u).
#ifndef ENVMAP_GLSL
#define ENVMAP_GLSL

vec2 envmap_uv(vec3 d) {
    d = normalize(d);
    float theta = acos(clamp(d.y, -1.0, 1.0));
    float phi = atan(d.z, d.x);
    if (phi < 0.0) phi += 2.0 * 3.14159265358979323846;
    return vec2(phi / (2.0 * 3.14159265358979323846), theta / 3.14159265358979323846);
}

vec3 envmap_direction(vec2 uv) {
    float theta = 3.14159265358979323846 * uv.y;
    float phi = 2.0 * 3.14159265358979323846 * uv.x;
    return vec3(sin(theta) * cos(phi), cos(theta), sin(theta) * sin(phi));
}

#endif
