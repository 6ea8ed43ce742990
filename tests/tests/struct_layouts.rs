//! Every `#[repr(C)]` struct the host shares with GLSL, checked against the compiled shader that reads
//! or writes it (engine::gpu::layout_check): member names, offsets, sizes, component types and the
//! struct's size or array stride. No GPU is needed: only shaderc and the SPIR-V reflection.
//!
//! Adding a struct is one line in `host_structs()`. The check lives here, above every engine layer,
//! because its table names structs from all of them (gpu, scene, passes, engine-blockers) and from the
//! test kernels of this crate; an engine unit test in `gpu` would import the layers above it.
//! Structs private to a test file (blocker_bvh.rs's `Query`) are checked in that file with the same macro.

use engine::blockers::bvh::GpuBvhNode;
use engine::gpu::layout_check::{check, check_all, HostLayout};
use engine::gpu::{default_shader_root, ShaderCompiler};
use engine::layout_check;
use engine::passes::blocker_bvh::RadixPush;
use engine::passes::blocker_spheres::AnimatePush;
use engine::passes::cloth::ClothPush;
use engine::passes::shade::isg::{GpuIsgParams, GpuSgLobe};
use engine::passes::shade::lobes::{GpuEnvLobe, GpuLobesParams};
use engine::passes::shade::reference::ReferenceParams;
use engine::passes::skin::SkinPush;
use engine::passes::thin_shells::ThinShellsPush;
use engine::resources::blockers::{GpuBlockerPlane, GpuBlockerSphere, GpuVertexSkin};
use engine::resources::layout::{FrameData, GpuMaterial, GpuObject, GpuVertex};
use engine::resources::lights::GpuSphereLight;
use engine::resources::thin::{GpuThinCluster, GpuThinTriangle};
use engine::scene::triangle_bvh::{GpuTriangle, TriNode};

/// One line per host struct: the type, a shader that uses it, which struct there, every field.
fn host_structs() -> Vec<HostLayout> {
    vec![
        // shaders-glsl/common/scene.glsl
        layout_check!(GpuVertex, "skin/skin.comp", struct "Vertex", [position, instance, normal, material]),
        layout_check!(GpuObject, "skin/skin.comp", struct "Object", [model, normal_matrix]),
        layout_check!(GpuMaterial, "shade/none/pixel.comp", struct "Material", [
            diffuse, kind, specular, shininess, brdf, lobes, tangent, lobes_along_b, more
        ]),
        layout_check!(FrameData, "shade/none/pixel.comp", struct "FrameData", [
            eye, pad0, right, tan_half_fov_x, up, tan_half_fov_y, forward, near, far, exposure, pad1, pad2,
            size, vertex_count, prefiltered_levels
        ]),
        layout_check!(FrameData, "gbuffer/gbuffer.vert", struct "FrameData", [
            eye, pad0, right, tan_half_fov_x, up, tan_half_fov_y, forward, near, far, exposure, pad1, pad2,
            size, vertex_count, prefiltered_levels
        ]),
        // skinning and blocker spheres
        layout_check!(GpuVertexSkin, "skin/skin.comp", struct "VertexSkin", [joints, weights]),
        layout_check!(SkinPush, "skin/skin.comp", push_constants, [vertex_count, bone_count]),
        layout_check!(GpuBlockerSphere, "blocker_spheres/animate.comp", struct "BlockerSphere", [
            sphere, joints, weights, object, pad0, pad1, pad2
        ]),
        layout_check!(AnimatePush, "blocker_spheres/animate.comp", push_constants, [sphere_count, bone_count]),
        // the sphere BVH (common/bvh.glsl; written by blocker_bvh, read by isg and the reference)
        layout_check!(GpuBvhNode, "blocker_bvh/hierarchy.comp", struct "BvhNode", [
            center, radius, left, right, parent, sphere
        ]),
        layout_check!(GpuBvhNode, "shade/isg/pixel.comp", struct "BvhNode", [
            center, radius, left, right, parent, sphere
        ]),
        layout_check!(RadixPush, "blocker_bvh/radix_count.comp", push_constants, [n, shift, tiles]),
        layout_check!(RadixPush, "blocker_bvh/radix_scan.comp", push_constants, [n, shift, tiles]),
        layout_check!(RadixPush, "blocker_bvh/radix_scatter.comp", push_constants, [n, shift, tiles]),
        // the cloth simulation (cloth/cloth.glsl: one push block, included by every kernel)
        layout_check!(
            ClothPush,
            "cloth/solve.comp",
            push_constants,
            [
                columns,
                rows,
                collider_count,
                vertex_base,
                dt,
                keep,
                relaxation,
                thickness,
                gravity,
                ground,
                alpha,
                has_ground,
                friction,
                sphere_first,
                sphere_patch,
                emit_spheres
            ]
        ),
        // thin shells (common/thin.glsl)
        layout_check!(GpuThinTriangle, "thin_shells/triangles.comp", struct "ThinTriangle", [v0, v1, v2]),
        layout_check!(GpuThinCluster, "thin_shells/triangles.comp", struct "ThinCluster", [
            bound, first, count, pad0, pad1
        ]),
        layout_check!(ThinShellsPush, "thin_shells/triangles.comp", push_constants, [cluster_count]),
        // technique `reference`
        layout_check!(
            ReferenceParams,
            "shade/reference/pixel.comp",
            push_constants,
            [
                sample_base,
                samples,
                seed,
                pad_lights,
                env_width,
                env_height,
                visibility,
                item_count,
                ray_offset,
                env_total,
                sphere_count,
                pad0
            ]
        ),
        // the scene's lights (shade/lights.glsl), read by every technique
        layout_check!(GpuSphereLight, "shade/reference/pixel.comp", struct "SphereLight", [
            center, radius, radiance, pad0
        ]),
        layout_check!(GpuSphereLight, "shade/isg/pixel.comp", struct "SphereLight", [
            center, radius, radiance, pad0
        ]),
        layout_check!(GpuSphereLight, "shade/none/vertex.comp", struct "SphereLight", [
            center, radius, radiance, pad0
        ]),
        // plane blockers (common/planes.glsl), read by isg and the reference
        layout_check!(GpuBlockerPlane, "shade/isg/pixel.comp", struct "BlockerPlane", [plane, center, half_u, half_v]),
        layout_check!(GpuBlockerPlane, "shade/reference/pixel.comp", struct "BlockerPlane", [
            plane, center, half_u, half_v
        ]),
        layout_check!(TriNode, "shade/reference/pixel.comp", struct "TriNode", [lo, first, hi, count]),
        layout_check!(GpuTriangle, "shade/reference/pixel.comp", struct "Tri", [v0, v1, v2]),
        // technique `isg`
        layout_check!(GpuIsgParams, "shade/isg/pixel.comp", struct "IsgParams", [
            lobe_count, side, evaluator, sphere_count, log_epsilon, node_threshold, cosine_lambda, cosine_mu,
            gather_take_whole, diffuse_mode, reach, pad1
        ]),
        layout_check!(GpuSgLobe, "shade/isg/pixel.comp", struct "EnvLobe", [axis, lambda, mu, pad0]),
        layout_check!(GpuLobesParams, "shade/lobes/pixel.comp", struct "LobesParams", [
            sphere_count, depth, conservative, threshold, weight, extent, light_mode, energy_scale, split, sharpen,
            take_whole, coarsen, light_weights, env_lobe_count, budget, env_black, light_alpha, reach
        ]),
        // read only by the env=lobes variant (LOBES_ENV_K > 0)
        engine::gpu::layout_check::HostLayout {
            defines: &[("LOBES_ENV_K", "4")],
            ..layout_check!(GpuEnvLobe, "shade/lobes/pixel.comp", struct "EnvLobe", [axis_e, scale])
        },
    ]
}

fn compiler() -> ShaderCompiler {
    ShaderCompiler::new(default_shader_root()).expect("shaderc and the shaders-glsl folder")
}

#[test]
fn host_structs_match_their_shaders() {
    let hosts = host_structs();
    if let Err(e) = check_all(&compiler(), &hosts) {
        panic!("{e}");
    }
    eprintln!("{} host structs match their shaders", hosts.len());
}

// The check can fail: deliberately wrong twins of real shader structs, each problem named.

#[test]
fn a_wrong_component_type_is_caught() {
    #[repr(C)]
    struct IntKind {
        diffuse: [f32; 3],
        kind: u32, // `float kind` in GLSL: the bits would be read as a float
        specular: [f32; 3],
        shininess: f32,
        brdf: [f32; 4],
        lobes: [f32; 4],
        tangent: [f32; 3],
        lobes_along_b: f32,
        more: [[f32; 4]; 2],
    }
    let host = layout_check!(IntKind, "shade/none/pixel.comp", struct "Material", [
        diffuse, kind, specular, shininess, brdf, lobes, tangent, lobes_along_b, more
    ]);
    let err = check(&compiler(), &host).unwrap_err();
    assert!(err.contains("IntKind.kind") && err.contains("component type"), "{err}");
}

#[test]
fn a_missing_padding_field_is_caught() {
    #[repr(C)]
    struct NoPad {
        axis: [f32; 3],
        lambda: f32,
        mu: [f32; 3],
    }
    let host = layout_check!(NoPad, "shade/isg/pixel.comp", struct "EnvLobe", [axis, lambda, mu]);
    let err = check(&compiler(), &host).unwrap_err();
    assert!(err.contains("3 fields") && err.contains("4 members"), "{err}");
    assert!(err.contains("size_of 28") && err.contains("array stride 32"), "{err}");
}

#[test]
fn swapped_fields_and_wrong_offsets_are_caught() {
    // A vec4 where GLSL has vec3 + float: every later offset moves.
    #[repr(C)]
    struct Swapped {
        normal: [f32; 4],
        position: [f32; 4],
    }
    let host = layout_check!(Swapped, "skin/skin.comp", struct "Vertex", [normal, position]);
    let err = check(&compiler(), &host).unwrap_err();
    assert!(err.contains("name differs: expected GLSL member 'normal'"), "{err}");
    assert!(err.contains("Swapped.position (GLSL Vertex.instance): offset 16 on the host, 12 in the shader"), "{err}");
    assert!(err.contains("16 bytes on the host, 12 in the shader"), "{err}");
}

#[test]
fn mapped_names_and_missing_structs() {
    // `as "glsl_name"` maps a field whose Rust name differs (e.g. a Rust keyword in GLSL's way).
    #[repr(C)]
    struct Mapped {
        n: u32,
        digit_shift: u32,
        tiles: u32,
    }
    let ok = layout_check!(Mapped, "blocker_bvh/radix_count.comp", push_constants, [
        n, digit_shift as "shift", tiles
    ]);
    check(&compiler(), &ok).expect("mapped name");
    let unmapped = layout_check!(Mapped, "blocker_bvh/radix_count.comp", push_constants, [n, digit_shift, tiles]);
    assert!(check(&compiler(), &unmapped).unwrap_err().contains("expected GLSL member 'digit_shift'"));
    // A struct the shader does not have (or that the optimizer removed, unused).
    let missing = layout_check!(Mapped, "skin/skin.comp", struct "NoSuchStruct", [n, digit_shift, tiles]);
    let err = check(&compiler(), &missing).unwrap_err();
    assert!(err.contains("no laid-out struct named 'NoSuchStruct'") && err.contains("Vertex"), "{err}");
    // Blocks by binding name.
    let block = layout_check!(Mapped, "skin/skin.comp", block "NoSuchBuffer", [n, digit_shift, tiles]);
    let err = check(&compiler(), &block).unwrap_err();
    assert!(err.contains("no buffer block bound as 'NoSuchBuffer'") && err.contains("VertexSkins"), "{err}");
}
