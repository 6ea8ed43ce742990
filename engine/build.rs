//! Link glslang and SPIRV-Tools statically next to Debian's `libshaderc_combined.a`
//! (docs/design.md §6: the shared libshaderc is underlinked and mismatched; never build glslang from source).
fn main() {
    println!("cargo:rerun-if-env-changed=SHADERC_LIB_DIR");
    let dir = std::env::var("SHADERC_LIB_DIR").unwrap_or_else(|_| "/usr/lib/x86_64-linux-gnu".into());
    if !std::path::Path::new(&dir).join("libshaderc_combined.a").exists() {
        println!(
            "cargo:warning=libshaderc_combined.a not found in {dir}: install libshaderc-dev \
             (cargo xtask demo does it) or set SHADERC_LIB_DIR"
        );
    }
    println!("cargo:rustc-link-search=native={dir}");
    for lib in [
        "glslang",
        "MachineIndependent",
        "GenericCodeGen",
        "OSDependent",
        "OGLCompiler",
        "SPIRV",
        "SPIRV-Tools-opt",
        "SPIRV-Tools",
    ] {
        println!("cargo:rustc-link-lib=static={lib}");
    }
}
