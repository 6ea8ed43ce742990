// Local frames. Twin: engine::passes::shade::isg::cpu::basis.
#ifndef FRAME_GLSL
#define FRAME_GLSL

// Orthonormal basis (t, b) around a unit z (Duff et al. 2017), right-handed, continuous except at
// z.z = −0; branchless but for the sign.
void orthonormal_basis(vec3 z, out vec3 t, out vec3 b) {
    float s = z.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + z.z);
    float c = z.x * z.y * a;
    t = vec3(1.0 + s * z.x * z.x * a, s * c, -s * z.x);
    b = vec3(c, s + z.y * z.y * a, -z.y);
}

#endif // FRAME_GLSL
