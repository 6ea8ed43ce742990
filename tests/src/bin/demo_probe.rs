//! Creates a GPU context and reports the error, if any, as the demo would (used by the
//! "no Vulkan device" test, which runs it with the loader pointed at no driver).
fn main() {
    scenes::init_logging();
    match engine::gpu::Gpu::new(&engine::gpu::GpuDesc { verbose: false, ..Default::default() }) {
        Ok(gpu) => {
            let _ = gpu.shutdown();
            println!("ok");
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
