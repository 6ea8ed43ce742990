#version 460
#extension GL_GOOGLE_include_directive : require
// blocker_bvh step 2: 30-bit Morton code of every sphere centre over the scene bounds (10 bits per axis,
// x most significant in each triple; twin of engine_blockers::bvh::morton_code), the identity
// permutation as sort values, and the refit counters cleared. A non-finite centre gets code 0.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Spheres { vec4 spheres[]; };
layout(std430, binding = 1) readonly buffer Bounds { vec4 bounds[2]; };
layout(std430, binding = 2) writeonly buffer Keys { uint keys[]; };
layout(std430, binding = 3) writeonly buffer Values { uint values[]; };
layout(std430, binding = 4) writeonly buffer Counters { uint counters[]; };
layout(push_constant) uniform Push { uint n; } pc;

uint expand_bits(uint v) {
    v &= 0x3ffu;
    v = (v | (v << 16)) & 0x030000ffu;
    v = (v | (v << 8)) & 0x0300f00fu;
    v = (v | (v << 4)) & 0x030c30c3u;
    v = (v | (v << 2)) & 0x09249249u;
    return v;
}

uint quantize(float x, float lo, float extent) {
    if (!(extent > 0.0)) {
        return 0u;
    }
    float q = (x - lo) / extent * 1024.0;
    // NaN fails both comparisons and lands on 0.
    return q >= 1023.0 ? 1023u : (q > 0.0 ? uint(q) : 0u);
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.n) {
        return;
    }
    vec3 lo = bounds[0].xyz;
    vec3 e = bounds[1].xyz - lo;
    vec3 c = spheres[i].xyz;
    uint code = 0u;
    if (!any(isnan(c)) && !any(isinf(c))) {
        code = (expand_bits(quantize(c.x, lo.x, e.x)) << 2) | (expand_bits(quantize(c.y, lo.y, e.y)) << 1)
            | expand_bits(quantize(c.z, lo.z, e.z));
    }
    keys[i] = code;
    values[i] = i;
    counters[i] = 0u;
}
