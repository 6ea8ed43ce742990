#version 460
#extension GL_GOOGLE_include_directive : require
// Twin test of common/brdf.glsl against engine/math/src/brdf.rs.
// Input, stride 37 floats per case: [0..28) the Material (the 28 floats of GpuMaterial, std430 order),
//   [28..31) n, [31..34) v, [34..37) l (unit vectors).
// Output, stride 56 floats per case:
//   [0..3) brdf_specular(m, n, t, v, l)   [3] brdf_dir_pdf(m, n, t, v, l)
//   [4..7) t = brdf_tangent(m, n)
//   [7 + 7j ..) lobe j (j < 7; zeros past the count): axis (3), λ, weight (3)
#include "../common/brdf.glsl"
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) readonly buffer Input { float data_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Output { float data_out[]; };
layout(push_constant) uniform Push { uint count; } pc;

const uint IN_STRIDE = 37u;
const uint OUT_STRIDE = 56u;

vec4 in4(uint b) {
    return vec4(data_in[b], data_in[b + 1u], data_in[b + 2u], data_in[b + 3u]);
}
vec3 in3(uint b) {
    return vec3(data_in[b], data_in[b + 1u], data_in[b + 2u]);
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    uint b = i * IN_STRIDE;
    Material m;
    m.diffuse = in3(b);
    m.kind = data_in[b + 3u];
    m.specular = in3(b + 4u);
    m.shininess = data_in[b + 7u];
    m.brdf = in4(b + 8u);
    m.lobes = in4(b + 12u);
    m.tangent = in3(b + 16u);
    m.lobes_along_b = data_in[b + 19u];
    m.more[0] = in4(b + 20u);
    m.more[1] = in4(b + 24u);
    vec3 n = in3(b + 28u);
    vec3 v = in3(b + 31u);
    vec3 l = in3(b + 34u);
    vec3 t = brdf_tangent(m, n);
    vec3 f = brdf_specular(m, n, t, v, l);
    uint o = i * OUT_STRIDE;
    for (uint k = 0u; k < OUT_STRIDE; ++k) data_out[o + k] = 0.0;
    data_out[o] = f.x;
    data_out[o + 1u] = f.y;
    data_out[o + 2u] = f.z;
    data_out[o + 3u] = brdf_dir_pdf(m, n, t, v, l);
    data_out[o + 4u] = t.x;
    data_out[o + 5u] = t.y;
    data_out[o + 6u] = t.z;
    SpecLobe lobes[BRDF_MAX_LOBES];
    int count = brdf_specular_lobes(m, n, v, lobes);
    for (int j = 0; j < count; ++j) {
        uint q = o + 7u + 7u * uint(j);
        data_out[q] = lobes[j].axis.x;
        data_out[q + 1u] = lobes[j].axis.y;
        data_out[q + 2u] = lobes[j].axis.z;
        data_out[q + 3u] = lobes[j].lambda;
        data_out[q + 4u] = lobes[j].weight.x;
        data_out[q + 5u] = lobes[j].weight.y;
        data_out[q + 6u] = lobes[j].weight.z;
    }
}
