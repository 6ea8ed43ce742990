// Sphere primitives for blocker culling and hierarchy cuts (f32 twins of engine_blockers::geom).
// A sphere is vec4(center.xyz, radius).
#ifndef SPHERES_GLSL
#define SPHERES_GLSL

const float SPHERES_PI = 3.14159265358979323846;

// Angle between two non-zero vectors via atan2 (accurate near 0 and pi, where acos(dot) loses digits).
// Twin: geom::angle_between.
float spheres_angle_between(vec3 a, vec3 b) {
    return atan(length(cross(a, b)), dot(a, b));
}

// Half-angle of the cone of directions from p that hit sphere s (SHEXP Eq. 34, asin(r/d)), written
// atan2(r, sqrt((d - r)(d + r))) to keep its digits as r/d -> 1. Inside or on the sphere: pi.
// Twin: geom::subtended_half_angle.
float sphere_subtended_half_angle(vec3 p, vec4 s) {
    float d = distance(p, s.xyz);
    if (d <= s.w) {
        return SPHERES_PI;
    }
    return atan(s.w, sqrt((d - s.w) * (d + s.w)));
}

// Whether sphere s meets the one-sided cone (apex, unit axis, half_angle): the sphere covers the cap
// of directions of half-angle psi around its centre direction beta, and meets the cone iff
// beta <= half_angle + psi (ISG Sec. 5 culling). Twin: geom::cone_intersects_sphere.
bool cone_intersects_sphere(vec3 apex, vec3 axis, float half_angle, vec4 s) {
    vec3 v = s.xyz - apex;
    if (length(v) <= s.w) {
        return true;
    }
    float psi = sphere_subtended_half_angle(apex, s);
    return spheres_angle_between(axis, v) <= half_angle + psi;
}

// SHEXP Eq. 36: s subtends less than theta_max from every point of the receiver sphere.
// Twin: geom::subtends_less_than.
bool sphere_subtends_less_than(vec4 receiver, vec4 s, float theta_max) {
    return s.w < sin(theta_max) * (distance(receiver.xyz, s.xyz) - receiver.w);
}

// Smallest sphere containing spheres a and b (SHEXP Sec. 6.3 pair bound). The radius is raised to the
// measured |c - c_i| + r_i so rounding never leaves a child outside. Twin: geom::merge_spheres.
vec4 merge_spheres(vec4 a, vec4 b) {
    float d = distance(a.xyz, b.xyz);
    if (d + b.w <= a.w) {
        return a;
    }
    if (d + a.w <= b.w) {
        return b;
    }
    float r = 0.5 * (d + a.w + b.w);
    float t = clamp((r - a.w) / d, 0.0, 1.0);
    vec3 c = a.xyz + (b.xyz - a.xyz) * t;
    r = max(r, max(distance(c, a.xyz) + a.w, distance(c, b.xyz) + b.w));
    return vec4(c, r);
}

// SHEXP §6.2 self-shadowing rules: the blocker that sphere s becomes for a receiver at p with unit
// normal n (tangent plane T_p). Returns false when s is eliminated. Twin: geom::blocker_for_receiver.
bool blocker_for_receiver(vec3 p, vec3 n, vec4 s, out vec4 blocker) {
    float h = dot(s.xyz - p, n);
    blocker = s;
    if (distance(s.xyz, p) <= s.w) {
        blocker = vec4(s.xyz, min(h, s.w));
        return h > 0.0;
    }
    if (h <= -s.w) return false;
    if (h >= s.w) return true;
    float t = h + s.w;
    blocker = vec4(s.xyz + n * (s.w - 0.5 * t), 0.5 * t);
    return true;
}

// The same with the paper's radius scale α (SHEXP §6.2, our reading): for p outside a sphere straddling
// T_p, the sphere tangent to T_p at q1 (the centre's foot) of radius (1 − α) max(h, 0) + α (h + r)/2,
// α = clamp((‖p − q1‖ − d)/d, 0, 1), d = √(r² − h²): the inside rule's blocker on the sphere, S' from
// ‖p − q1‖ = 2d on. Twin: geom::blocker_for_receiver_alpha.
bool blocker_for_receiver_alpha(vec3 p, vec3 n, vec4 s, out vec4 blocker) {
    float h = dot(s.xyz - p, n);
    if (distance(s.xyz, p) <= s.w || h <= -s.w || h >= s.w) return blocker_for_receiver(p, n, s, blocker);
    vec3 q1 = s.xyz - n * h;
    float d = sqrt(max(s.w * s.w - h * h, 0.0));
    float a = d > 0.0 ? clamp((distance(p, q1) - d) / d, 0.0, 1.0) : 1.0;
    float r = (1.0 - a) * max(h, 0.0) + a * 0.5 * (h + s.w);
    blocker = vec4(q1 + n * r, r);
    return r > 0.0;
}

#endif // SPHERES_GLSL
