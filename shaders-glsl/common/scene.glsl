// Host/shader structs (std430). Rust twins: engine/src/passes/layout.rs, checked against these
// declarations by tests/tests/struct_layouts.rs.
#ifndef SCENE_GLSL
#define SCENE_GLSL

const float PI = 3.14159265358979323846;

// Twin: engine::passes::layout::GpuVertex. The indices are exact in f32 below 2^24.
struct Vertex {
    vec3 position;
    float instance;  // index into the objects (instance transforms)
    vec3 normal;
    float material;  // index into the materials
};

struct Object {
    mat4 model;
    mat4 normal_matrix;
};

// brdf holds the parameters of the model `kind` names: Cook-Torrance (α, λ_h, μ, 0),
// Ashikhmin-Shirley (n_u, n_v, λ_h, δ) or Lafortune (C_x, C_y, C_z, e) of its lobe 0, unused for Blinn-Phong;
// lobes = per-lobe amplitudes: Ashikhmin-Shirley μ_|k|, k = 0..3 (indexed by k), Lafortune (1, w_1, w_2, 0)
// (w_i = 0: lobe i absent) with the (C, e) of lobes 1 and 2 in `more`. Twin: engine::passes::layout::GpuMaterial (filled from
// engine::scene::Material).
struct Material {
    vec3 diffuse;         // ρ_d
    float kind;           // BRDF kind: 0 Blinn-Phong, 1 Cook-Torrance Beckmann, 2 Cook-Torrance GGX,
                          // 3 Ashikhmin-Shirley, 4 Lafortune (exact small integers)
    vec3 specular;        // k_s (F0)
    float shininess;      // Blinn-Phong exponent s
    vec4 brdf;
    vec4 lobes;
    vec3 tangent;         // anisotropy direction
    float lobes_along_b;  // 1: the Ashikhmin-Shirley lobes lie along b, 0: along t
    vec4 more[2];         // Lafortune: (C_x, C_y, C_z, e) of lobes 1 and 2
};

// Twin: engine::passes::layout::FrameData.
struct FrameData {
    vec3 eye;                 // camera position
    float pad0;
    vec3 right;               // camera right (unit)
    float tan_half_fov_x;     // tan(fov_y / 2) * aspect
    vec3 up;                  // camera up (unit)
    float tan_half_fov_y;     // tan(fov_y / 2)
    vec3 forward;             // camera forward (unit)
    float near;               // near plane distance
    float far;                // far plane distance
    float exposure;           // tone-mapping scale of the radiance
    float pad1;
    float pad2;
    uvec2 size;               // width, height (pixels)
    uint vertex_count;
    uint prefiltered_levels;  // levels of the prefiltered environment atlas (shade/prefiltered.glsl)
};

#endif
