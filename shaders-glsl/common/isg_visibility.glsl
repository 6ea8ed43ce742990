// Visibility of one spherical Gaussian lobe by integral spherical Gaussians over a patch grid
// (Iwasaki et al. 2012, Sec. 4.1 and 5). f32 twin of engine::passes::shade::isg::cpu.
//
// For a lobe with unit axis a and sharpness λ at receiver p (unit normal n):
// 1. the limiting angle Γ: exp(λ(cos Γ − 1)) = ε (Γ = π/2 when λ ≤ −ln ε);
// 2. a P × P grid of patches over (θ, φ) ∈ [π/2 − Γ, π/2 + Γ]² in the ISG frame
//    Ω(θ, φ) = (sin θ cos φ, cos θ, sin θ sin φ) with the axis at (π/2, π/2) (see isg.glsl);
// 3. the sphere BVH is traversed with a cone around a that covers the grid; a node whose angular
//    radius is below `node_threshold` patch widths is taken whole, leaves always; each blocker passes
//    the SHEXP self-shadowing rule (spheres.glsl) and marks the patches whose CENTRE direction lies
//    in its cap of directions (exact per row: one acos per row);
// 4. occluded patches are summed run by run along each row with the four-corner rule of Ŝ.
// The result is the occluded part of the lobe's integral normalized by its hemisphere integral
// (Ŝ units): visible integral = μ (F(λ) − H(λ) · occluded), F the sphere and H the hemisphere integral.
//
// The includer defines, before including this file:
//   ISG_BVH_NODE(i)   an expression giving BvhNode number i (bvh.glsl), e.g. bvh_nodes[i];
//   ISG_LUT_FETCH(i)  float number i of the ISG table (isg.glsl), for the table evaluator.
#ifndef ISG_VISIBILITY_GLSL
#define ISG_VISIBILITY_GLSL

#include "isg.glsl"
#include "bvh.glsl"

// Patches per side at most (one 32-bit mask word per row).
#define ISG_MAX_SIDE 32

const int ISG_EVAL_TABLE = 0;
const int ISG_EVAL_PAPER = 1;

struct IsgSettings {
    int side;              // patches per side P, 1..32 (P² patches)
    float log_epsilon;     // ln ε of the limiting angle (ε = 0.01 by default)
    float node_threshold;  // a BVH node is taken whole below this angular radius, in patch widths
    int evaluator;         // ISG_EVAL_TABLE or ISG_EVAL_PAPER
};

struct IsgGrid {
    vec3 x;          // local frame: z = lobe axis, y = pole of the (θ, φ) parameterization
    vec3 y;
    vec3 z;
    float lo;        // π/2 − Γ: first grid line in θ and in φ
    float delta;     // patch width 2Γ / P
    int side;
    float cone;      // half-angle of the cone around z that holds the whole grid: acos(cos² Γ)
};

float isg_limiting_angle(float lambda, float log_epsilon) {
    float c = 1.0 + log_epsilon / max(lambda, 1e-30);
    return c <= 0.0 ? ISG_HALF_PI : acos(c);
}

// Orthonormal basis around a unit z (Duff et al. 2017, branchless and continuous except at z.z = −0).
void isg_basis(vec3 z, out vec3 x, out vec3 y) {
    float s = z.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + z.z);
    float b = z.x * z.y * a;
    x = vec3(1.0 + s * z.x * z.x * a, s * b, -s * z.x);
    y = vec3(b, s + z.y * z.y * a, -z.y);
}

IsgGrid isg_grid(vec3 axis, float lambda, IsgSettings st) {
    IsgGrid g;
    g.z = axis;
    isg_basis(axis, g.x, g.y);
    float gamma = isg_limiting_angle(lambda, st.log_epsilon);
    g.side = clamp(st.side, 1, ISG_MAX_SIDE);
    g.lo = ISG_HALF_PI - gamma;
    g.delta = 2.0 * gamma / float(g.side);
    float c = cos(gamma);
    g.cone = acos(clamp(c * c, 0.0, 1.0));
    return g;
}

// Bits j0..j1 (inclusive) of a row mask.
uint isg_bit_range(int j0, int j1) {
    uint upto = j1 >= 31 ? 0xffffffffu : ((2u << uint(j1)) - 1u);
    return upto & ~((1u << uint(j0)) - 1u);
}

// Patches whose centre lies in the cap of half-angle psi around the unit direction u.
void isg_mark_cap(inout uint mask[ISG_MAX_SIDE], IsgGrid g, vec3 u, float psi) {
    uint full = isg_bit_range(0, g.side - 1);
    if (psi >= ISG_PI) {
        for (int i = 0; i < g.side; ++i) mask[i] = full;
        return;
    }
    float ux = dot(u, g.x);
    float uy = dot(u, g.y);
    float uz = dot(u, g.z);
    float rho = sqrt(ux * ux + uz * uz);
    float theta_c = atan(rho, uy);
    float phi_c = rho > 0.0 ? atan(uz, ux) : 0.0;
    float cos_psi = cos(psi);
    float last = float(g.side - 1);
    int i_lo = int(clamp(ceil((theta_c - psi - g.lo) / g.delta - 0.5), 0.0, last + 1.0));
    int i_hi = int(clamp(floor((theta_c + psi - g.lo) / g.delta - 0.5), -1.0, last));
    for (int i = i_lo; i <= i_hi; ++i) {
        float th = g.lo + (float(i) + 0.5) * g.delta;
        float denom = sin(th) * rho;
        float rhs = cos_psi - cos(th) * uy;
        uint bits = 0u;
        if (denom < 1e-7) {
            bits = rhs <= 0.0 ? full : 0u;
        } else {
            float q = rhs / denom;
            if (q <= -1.0) {
                bits = full;
            } else if (q <= 1.0) {
                float w = acos(q);
                for (int k = -1; k <= 1; ++k) {
                    float c = phi_c + 2.0 * ISG_PI * float(k);
                    int j_lo = int(clamp(ceil((c - w - g.lo) / g.delta - 0.5), 0.0, last + 1.0));
                    int j_hi = int(clamp(floor((c + w - g.lo) / g.delta - 0.5), -1.0, last));
                    if (j_lo <= j_hi) bits |= isg_bit_range(j_lo, j_hi);
                }
            }
        }
        mask[i] |= bits;
    }
}

// Ŝ at one corner: the table (with the per-λ warp constants wc and slice fl) or the paper's fit.
float isg_corner(float theta, float phi, float lambda, int evaluator, vec2 wc, float fl) {
#ifdef ISG_LUT_FETCH
    if (evaluator == ISG_EVAL_TABLE) {
        return isg_lut_at(isg_lut_warp(theta, wc), isg_lut_warp(phi, wc), fl);
    }
#endif
    return isg_paper(theta, phi, lambda);
}

// Sum of the normalized ISG over the marked patches, run by run along each row.
float isg_occluded_sum(uint mask[ISG_MAX_SIDE], IsgGrid g, float lambda, int evaluator) {
    vec2 wc = isg_lut_warp_consts(lambda);
    float fl = isg_lut_slice(lambda);
    float sum = 0.0;
    for (int i = 0; i < g.side; ++i) {
        uint m = mask[i];
        if (m == 0u) continue;
        float t0 = g.lo + float(i) * g.delta;
        float t1 = t0 + g.delta;
        while (m != 0u) {
            int j0 = findLSB(m);
            uint ones = m >> uint(j0);
            int run = findLSB(~ones);
            if (run < 0) run = 32 - j0;
            int j1 = j0 + run;  // exclusive
            m &= ~isg_bit_range(j0, j1 - 1);
            float p0 = g.lo + float(j0) * g.delta;
            float p1 = g.lo + float(j1) * g.delta;
            sum += isg_corner(t1, p1, lambda, evaluator, wc, fl) - isg_corner(t0, p1, lambda, evaluator, wc, fl)
                 - isg_corner(t1, p0, lambda, evaluator, wc, fl) + isg_corner(t0, p0, lambda, evaluator, wc, fl);
        }
    }
    return max(sum, 0.0);
}

// Occluded part of the lobe (axis, λ) seen from p (normal n), in Ŝ units (see the top of the file).
float isg_occlusion(vec3 p, vec3 n, vec3 axis, float lambda, IsgSettings st, uint sphere_count) {
    if (sphere_count == 0u) return 0.0;
    IsgGrid g = isg_grid(axis, lambda, st);
    uint mask[ISG_MAX_SIDE];
    for (int i = 0; i < ISG_MAX_SIDE; ++i) mask[i] = 0u;
    bool marked = false;
    float take_whole = st.node_threshold * g.delta;
    BvhCursor cur = bvh_cursor_begin(sphere_count);
    uint node;
    while (bvh_cursor_next(cur, node)) {
        BvhNode b = ISG_BVH_NODE(node);
        vec4 s = bvh_sphere(b);
        if (!bvh_cone_hits(p, axis, g.cone, s)) continue;
        if (!bvh_is_leaf(b)) {
            // Descend while the node is large on the grid (always when p is inside it); a node that is
            // small, or that does not fit on the stack, is taken whole (conservative: it bounds its leaves).
            float psi = sphere_subtended_half_angle(p, s);
            if (psi >= take_whole && bvh_cursor_push_children(cur, b.left, b.right)) continue;
        }
        vec4 blk;
        if (!blocker_for_receiver(p, n, s, blk) || blk.w <= 0.0) continue;
        vec3 d = blk.xyz - p;
        float dist = length(d);
        if (dist <= 0.0) continue;
        isg_mark_cap(mask, g, d / dist, sphere_subtended_half_angle(p, blk));
        marked = true;
    }
    return marked ? isg_occluded_sum(mask, g, lambda, st.evaluator) : 0.0;
}

#endif // ISG_VISIBILITY_GLSL
