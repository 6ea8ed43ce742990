#version 460
// Cost of the ISG evaluators of common/isg.glsl on the device (tests/tests/math_gpu_isg.rs,
// `isg_gpu_cost`, #[ignore]d: a measurement, not a check). Every invocation draws ISG_COST_PER
// queries by an additive recurrence from its index — λ log-uniform in [1e-2, 1e5], angles uniform in [0, π], patch
// sides up to 4 lobe widths (as engine/math/benches/math.rs) — and writes the sum of the results.
// ISG_COST_EVAL picks what is timed: 0 nothing (the query generation alone, subtracted as the
// baseline), 1 isg_paper, 2 isg_lut, 3 isg_paper_patch, 4 isg_lut_patch. ISG_COST_NO_READS
// replaces the table reads by arithmetic (wrong values; shows what the reads cost);
// ISG_COST_SCALAR_READS reads each vec4 entry as 4 floats.
layout(local_size_x = 64) in;
#ifdef ISG_COST_SCALAR_READS
layout(std430, set = 0, binding = 0) readonly buffer Table { float isg_table[]; };
#else
layout(std430, set = 0, binding = 0) readonly buffer Table { vec4 isg_table[]; };
#endif
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

#ifdef ISG_COST_NO_READS
// Diagnostic: the table reads replaced by arithmetic on the index (the cost of everything else).
#define ISG_LUT_FETCH(index) (vec4(float(index)) * vec4(1e-5, 2e-5, 3e-5, 4e-5))
#elif defined(ISG_COST_SCALAR_READS)
// The same table read as 4 scalar floats per entry.
#define ISG_LUT_FETCH(index) vec4(isg_table[4 * (index)], isg_table[4 * (index) + 1], isg_table[4 * (index) + 2], isg_table[4 * (index) + 3])
#else
#define ISG_LUT_FETCH(index) isg_table[index]
#endif
#include "../common/isg.glsl"

#ifndef ISG_COST_EVAL
#define ISG_COST_EVAL 0
#endif
#ifndef ISG_COST_PER
#define ISG_COST_PER 32
#endif

// Additive recurrence (fract(x + golden ratio)): cheap, so that the evaluators dominate the time.
float cost_unit(inout float u) {
    u = fract(u + 0.61803398875);
    return u;
}

void main() {
    uint id = gl_GlobalInvocationID.x;
    if (id >= pc.count) {
        return;
    }
    float h = fract(float(id) * 0.7548776662 + 0.5698402910 * float(id >> 12u));
    float acc = 0.0;
    for (int k = 0; k < ISG_COST_PER; ++k) {
        float lambda = exp2(mix(-6.643856, 16.609640, cost_unit(h)));  // log2 1e-2, log2 1e5
        float w = min(4.0 * inversesqrt(lambda), ISG_HALF_PI);
        float t0 = clamp(ISG_HALF_PI + w * (2.0 * cost_unit(h) - 1.0), 0.0, ISG_PI);
        float p0 = clamp(ISG_HALF_PI + w * (2.0 * cost_unit(h) - 1.0), 0.0, ISG_PI);
        float t1 = min(t0 + 0.5 * w * cost_unit(h), ISG_PI);
        float p1 = min(p0 + 0.5 * w * cost_unit(h), ISG_PI);
#if ISG_COST_EVAL == 0
        acc += t0 * p1 + t1 * p0 + lambda;
#elif ISG_COST_EVAL == 1
        acc += isg_paper(t1, p1, lambda);
#elif ISG_COST_EVAL == 2
        acc += isg_lut(t1, p1, lambda);
#elif ISG_COST_EVAL == 3
        acc += isg_paper_patch(t0, t1, p0, p1, lambda);
#else
        acc += isg_lut_patch(t0, t1, p0, p1, lambda);
#endif
    }
    data_out[id] = acc;
}
