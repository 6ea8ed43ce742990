//! A steady frame allocates no device memory (the allocator's counters over 100 frames).

use engine::renderer::{RenderSettings, Renderer};

#[test]
fn steady_frames_allocate_nothing() {
    let gpu = engine_tests::gpu();
    let scene = scenes::build("furnace", None).unwrap();
    let mut r = Renderer::new(
        &gpu,
        &scene,
        RenderSettings { width: 32, height: 24, technique: "none".into(), ..Default::default() },
    )
    .unwrap();
    r.render(&gpu).unwrap();
    let first = gpu.memory_stats();
    for _ in 0..100 {
        r.render(&gpu).unwrap();
    }
    let after = gpu.memory_stats();
    assert_eq!(after.allocations_made, first.allocations_made, "steady frames allocated device memory");
    assert_eq!(after.allocated_bytes, first.allocated_bytes);
    r.destroy(&gpu);
    gpu.shutdown().expect("clean teardown");
}
