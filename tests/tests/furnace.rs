//! Furnace: constant environment L over a Lambertian plane of albedo ρ with nothing above it:
//! every covered pixel shades to ρL within 1 %, per pixel and per vertex.

use engine::renderer::RenderSettings;

#[test]
fn lambertian_plane_under_constant_environment() {
    let gpu = engine_tests::gpu();
    let (albedo, radiance) = (0.5f32, 2.0f32);
    let scene = scenes::furnace::scene(albedo, radiance);
    for per_vertex in [false, true] {
        let settings =
            RenderSettings { width: 64, height: 48, per_vertex, technique: "none".into(), ..Default::default() };
        let (hdr, _) = engine_tests::render(&gpu, &scene, settings);
        let expected = albedo * radiance;
        // The camera looks straight down at a 2x2 plane filling the centre of the view.
        let mut checked = 0;
        for y in 16..32 {
            for x in 20..44 {
                let i = (y * 64 + x) * 4;
                for c in 0..3 {
                    let v = hdr[i + c];
                    // 1 %: the irradiance map's discrete clamped-cosine sum is within 0.2 % of π.
                    assert!(
                        (v - expected).abs() <= 0.01 * expected,
                        "per_vertex={per_vertex} pixel ({x},{y}): {v} vs {expected}"
                    );
                }
                checked += 1;
            }
        }
        assert_eq!(checked, 16 * 24);
    }
    gpu.shutdown().expect("clean teardown");
}
