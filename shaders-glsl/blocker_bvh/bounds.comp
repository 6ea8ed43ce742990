#version 460
#extension GL_GOOGLE_include_directive : require
// blocker_bvh step 1: scene bounds of the sphere centres (one workgroup, strided loop + shared-memory
// reduction; O(n)). Non-finite centres are skipped (they are sanitized in morton.comp). With no finite
// centre the bounds are the empty box (lo = +inf, hi = -inf), which morton.comp maps to code 0.
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Spheres { vec4 spheres[]; };
layout(std430, binding = 1) writeonly buffer Bounds { vec4 bounds[2]; };
layout(push_constant) uniform Push { uint n; } pc;

shared vec3 s_lo[256];
shared vec3 s_hi[256];

void main() {
    uint t = gl_LocalInvocationID.x;
    vec3 lo = vec3(uintBitsToFloat(0x7f800000u));
    vec3 hi = -lo;
    for (uint i = t; i < pc.n; i += 256u) {
        vec3 c = spheres[i].xyz;
        if (!any(isnan(c)) && !any(isinf(c))) {
            lo = min(lo, c);
            hi = max(hi, c);
        }
    }
    s_lo[t] = lo;
    s_hi[t] = hi;
    barrier();
    for (uint stride = 128u; stride > 0u; stride >>= 1u) {
        if (t < stride) {
            s_lo[t] = min(s_lo[t], s_lo[t + stride]);
            s_hi[t] = max(s_hi[t], s_hi[t + stride]);
        }
        barrier();
    }
    if (t == 0u) {
        bounds[0] = vec4(s_lo[0], 0.0);
        bounds[1] = vec4(s_hi[0], 0.0);
    }
}
