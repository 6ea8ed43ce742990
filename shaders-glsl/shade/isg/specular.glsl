// ISG specular term for the lobed BRDFs (Cook-Torrance: 1 lobe, Ashikhmin-Shirley: 7 lobes; ISG Eq. 9):
// each lobe's prefiltered lighting times its own visibility ratio, the visible over the upper-hemisphere
// integral of the product of that lobe and the cosine lobe. Blinn-Phong stays in shade.glsl.
// Included by shade.glsl after isg_visibility.glsl. CPU twin: engine::passes::shade::isg::cpu::specular.
#ifndef ISG_SPECULAR_GLSL
#define ISG_SPECULAR_GLSL

// Eq. 9 ratio of one unit lobe (axis, λ) at a point (1 without blockers or for a lobe without extent
// above the horizon). Blockers: spheres, thin-shell triangles and planes.
float isg_lobe_visibility_ratio(vec3 p, vec3 n, vec3 axis, float lambda, IsgSettings st, uint spheres,
                                float cos_lambda, float cos_mu) {
    // Thin shells: common/isg_thin.glsl; planes: common/isg_planes.glsl.
    if (spheres == 0u && !isg_thin_present() && !isg_planes_present()) return 1.0;
    vec3 pa;
    float pl;
    sg_product_log(normalize(axis), lambda, 1.0, n, cos_lambda, cos_mu, pa, pl);
    vec2 occ = isg_occlusion(p, n, pa, pl, st, spheres);
    float full = 2.0 * PI * sg_unit_integral_over_2pi(pl);
    float h = isg_normalization(pl);
    float above = full - h * occ.x;
    return above > 0.0 ? clamp((full - h * occ.y) / above, 0.0, 1.0) : 1.0;
}

// Σ_j w_j ∫ L G_j · ratio_j, clamped at 0.
vec3 isg_specular_lobes(ShadePoint sp, IsgSettings st, uint spheres, float cos_lambda, float cos_mu) {
    SpecLobe lobes[BRDF_MAX_LOBES];
    int count = brdf_specular_lobes(sp.material, sp.normal, sp.view, lobes);
    vec3 sum = vec3(0.0);
    for (int j = 0; j < count; ++j) {
        if (all(equal(lobes[j].weight, vec3(0.0)))) continue;
        float ratio = isg_lobe_visibility_ratio(sp.position, sp.normal, lobes[j].axis, lobes[j].lambda, st, spheres,
                                                cos_lambda, cos_mu);
        sum += lobes[j].weight * prefiltered_lobe_integral(prefiltered_env, lobes[j]) * ratio;
    }
    return max(sum, vec3(0.0));
}

#endif
