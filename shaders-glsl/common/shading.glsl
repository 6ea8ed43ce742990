// The shading frame of a two-sided surface point: the side the viewer sees (the geometric normal's)
// and a shading normal that faces the viewer. Twin of engine/math/src/shading.rs, whose module doc
// gives the derivation; applied where every ShadePoint is built (the G-buffer pass, the per-vertex
// targets), so every technique and the reference shade with the same normal.
#ifndef COMMON_SHADING_GLSL
#define COMMON_SHADING_GLSL

// Margin by which the adapted mirror direction leaves the geometric surface.
float reflection_margin(float gv) {
    return min(0.9 * gv, 0.01);
}

// Local shading normal adaptation (Keller et al. 2017, "The Iray Light Transport Simulation and
// Rendering System", arXiv:1705.01263, §A.3; as Cycles' ensure_valid_reflection): when the mirror
// direction of v about n_s does not leave the geometric surface by τ, or n_s faces away from the
// viewer (then r = −v, the limit at n_s·v = 0), lift r along n_g to n_g·r = τ and return the half
// vector of v and the lifted r̂. n_s, n_g, v unit; n_g·v ≥ 0; n_s on n_g's side.
vec3 adapt_shading_normal(vec3 n_s, vec3 n_g, vec3 v) {
    float gv = dot(n_g, v);
    float tau = reflection_margin(gv);
    float nv = dot(n_s, v);
    vec3 r = nv > 0.0 ? 2.0 * nv * n_s - v : -v;
    float rg = dot(r, n_g);
    if (nv > 0.0 && rg >= tau) return n_s;
    vec3 lifted = r + (tau - rg) * n_g;
    float len = length(lifted);
    if (!(len > 0.0)) return n_g;
    vec3 h = v + lifted / len;
    float hl = length(h);
    return hl > 0.0 ? h / hl : n_g;
}

// From the unit interpolated normal n_s and the unit geometric normal n_g (either orientation) seen
// along unit v (towards the viewer): n_g turned to the viewer, n_s turned to n_g's side and adapted.
void shading_normals(vec3 n_s, vec3 n_g, vec3 v, out vec3 shading, out vec3 geometric) {
    geometric = dot(n_g, v) < 0.0 ? -n_g : n_g;
    vec3 s = dot(n_s, geometric) < 0.0 ? -n_s : n_s;
    shading = adapt_shading_normal(s, geometric, v);
}
#endif
