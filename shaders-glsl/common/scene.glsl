// Host/shader structs (std430). Rust twins: engine/src/passes/layout.rs (with layout tests).
#ifndef SCENE_GLSL
#define SCENE_GLSL

const float PI = 3.14159265358979323846;

// position.w = instance index, normal.w = material index (exact in f32 below 2^24).
struct Vertex {
    vec4 position;
    vec4 normal;
};

struct Object {
    mat4 model;
    mat4 normal_matrix;
};

// diffuse.rgb = ρ_d, diffuse.w = BRDF kind (0 Blinn-Phong, 1 Cook-Torrance Beckmann, 2 Cook-Torrance
// GGX, 3 Ashikhmin-Shirley); specular.rgb = k_s (F0), specular.w = Blinn-Phong exponent s;
// brdf = Cook-Torrance (α, λ_h, μ, 0) or Ashikhmin-Shirley (n_u, n_v, λ_h, δ); lobes = Ashikhmin-Shirley
// amplitudes μ_|k|, k = 0..3; tangent.xyz = anisotropy direction, tangent.w = 1: lobes along b.
// Twin: engine::passes::layout::GpuMaterial (filled from engine::scene::Material).
struct Material {
    vec4 diffuse;
    vec4 specular;
    vec4 brdf;
    vec4 lobes;
    vec4 tangent;
};

struct FrameData {
    vec4 eye;       // xyz: camera position
    vec4 right;     // xyz: camera right; w: tan(fov_y / 2) * aspect
    vec4 up;        // xyz: camera up; w: tan(fov_y / 2)
    vec4 forward;   // xyz: camera forward; w: near plane
    vec4 params;    // x: far plane, y: exposure, z, w: unused
    uvec4 size;     // x: width, y: height, z: vertex count, w: prefiltered levels
};

#endif
