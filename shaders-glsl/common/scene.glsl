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

// diffuse.rgb = ρ_d; specular.rgb = k_s, specular.w = Blinn-Phong exponent s.
struct Material {
    vec4 diffuse;
    vec4 specular;
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
