// Linear blend skinning shared by the skin pass and the blocker_spheres pass (the same bone matrices
// move vertices and spheres). Requires, before inclusion, a buffer with `mat4 bones[]`.
// Host twin: engine::passes::blocker_spheres::GpuVertexSkin (checked by tests/tests/struct_layouts.rs).
#ifndef SKINNING_GLSL
#define SKINNING_GLSL

struct VertexSkin {
    uvec4 joints;
    vec4 weights; // sum 1, or 0 for "rigid: follow the instance only"
};

// Σ w_j B_j, or the identity when the weights sum to 0. Bones out of range count as the identity
// (the host rejects such skins; this only keeps a bad index from reading outside the buffer).
mat4 skin_matrix(uvec4 joints, vec4 weights, uint bone_count) {
    float total = weights.x + weights.y + weights.z + weights.w;
    if (!(total > 0.0)) {
        return mat4(1.0);
    }
    mat4 m = mat4(0.0);
    for (int k = 0; k < 4; ++k) {
        m += weights[k] * (joints[k] < bone_count ? bones[joints[k]] : mat4(1.0));
    }
    return m;
}

// Cofactor matrix det(M) M^-T: transforms normals like the inverse transpose, without dividing by the
// determinant (the caller normalizes), so a degenerate blend gives a zero normal instead of inf.
mat3 skin_cofactor(mat3 m) {
    return mat3(cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1]));
}

#endif // SKINNING_GLSL
