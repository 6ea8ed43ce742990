//! The short soak (the long one is `cargo xtask soak`, 10,000 frames): 300 animated frames at 32×24 through
//! the viewer's per-frame path without a window (lab::soak), every technique in turn, per pixel and per
//! vertex, with the validation layer on. Host memory (VmRSS) and device memory (gpu-allocator's report) must
//! stay within the bounds of `SoakOptions` after the warm-up cycle.

use lab::soak::{run, SoakOptions};

#[test]
fn three_hundred_animated_frames_keep_memory_flat() {
    let gpu = engine_tests::gpu();
    let techniques = engine::passes::shade::TECHNIQUES.len() as u64;
    // One cycle = every technique for `switch_every` frames; 300 frames = three cycles whatever the number of
    // registered techniques (3 today: 99 frames per cycle, 8 switches): the device baseline after the first,
    // the host baseline after the second (host memory settles more slowly: SoakOptions::host_warmup_cycles),
    // and one measured cycle for both.
    let options = SoakOptions {
        width: 32,
        height: 24,
        scenes: vec!["arm".into()],
        switch_every: (300 / (3 * techniques)).max(2),
        // Measured here: the trimmed RSS rose 3.8 and 5.0 MiB over the second and third 99-frame cycles (three
        // technique switches each; the isg preparation dominates). 16 MiB fails a leak of ~160 KiB a frame or
        // ~5 MiB a switch; `cargo xtask soak` measures the slope over 10,000 frames.
        host_growth_bound: 16 << 20,
        ..SoakOptions::new(300)
    };
    let report = run(&gpu, &options).unwrap_or_else(|e| panic!("{e:#}"));
    eprintln!("{}", report.summary());
    assert_eq!(report.frames, 300);
    assert!(report.samples.len() >= 2, "{:?}", report.samples);
    assert!(report.host_warm.frame > report.warm.frame, "{report:?}");
    assert!(report.switches >= 3 * techniques - 1, "{}", report.switches);
    assert!(report.host_growth() <= options.host_growth_bound);
    assert!(report.device_growth() <= options.device_growth_bound);
    gpu.shutdown().unwrap();
}

#[test]
fn the_rss_reader_reads_this_process() {
    let rss = lab::soak::host_rss().unwrap();
    // A test binary with the engine linked in is at least a few MiB and far below 100 GiB.
    assert!(rss > 1 << 20 && rss < 100 << 30, "{rss}");
    // It tracks an allocation that is touched (64 MiB, every page written).
    let block = vec![1u8; 64 << 20];
    let after = lab::soak::host_rss().unwrap();
    assert!(after >= rss + (48 << 20), "{rss} -> {after}");
    drop(block);
}
