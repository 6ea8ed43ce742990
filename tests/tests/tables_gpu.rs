//! The math tables load into device memory: every committed table (assets/tables) becomes one named buffer holding
//! exactly the file's payload, and they are all freed again (a leak fails `gpu.shutdown()`).

use engine::gpu::testing::test_gpu;
use engine::math::table_gen::{all_tables, MathTable};
use engine::math::tables::Table;
use engine::tables::{default_dir, MathTables, TablesError};

#[test]
fn all_tables_load_and_free() {
    let gpu = test_gpu().expect("GPU");
    let tables = MathTables::load_all(&gpu, &default_dir()).expect("load tables");
    assert_eq!(tables.len(), all_tables().len());
    // Issue 3: all tables together stay under 16 MiB of device memory.
    assert!(tables.total_bytes() <= 16 << 20, "{} bytes", tables.total_bytes());
    for g in tables.iter() {
        assert_eq!(g.header.name, g.table.name());
        assert!(g.buffer.desc.size >= g.header.payload_bytes(), "{}", g.header.name);
    }
    // The device copy is the file's payload, word for word (a small and the largest table).
    for t in [MathTable::LobeCap, MathTable::ShGamma(4), MathTable::LobeProduct] {
        let file = Table::read(&default_dir().join(format!("{}.bin", t.name()))).expect("read");
        let g = tables.get(t).expect("loaded");
        let words: Vec<u32> = gpu.read_buffer(&g.buffer).expect("read back");
        assert_eq!(&words[..file.words.len()], &file.words[..], "{}", t.name());
    }
    tables.destroy(&gpu);
    gpu.shutdown().expect("no leaks, no validation errors");
}

#[test]
fn missing_or_corrupt_tables_fail_cleanly() {
    let gpu = test_gpu().expect("GPU");
    let dir = std::env::temp_dir().join(format!("tables-gpu-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // The cap table is fine, the circle table missing: the cap buffer must be freed again.
    std::fs::copy(default_dir().join("lobe_cap.bin"), dir.join("lobe_cap.bin")).unwrap();
    let err = MathTables::load(&gpu, &dir, &[MathTable::LobeCap, MathTable::ShCircleLog(4)]).err().expect("missing");
    let msg = err.to_string();
    assert!(msg.contains("sh4_circle_log") && msg.contains("cargo xtask tables"), "{msg}");
    // A flipped payload byte is a checksum error naming the file.
    let mut bytes = std::fs::read(dir.join("lobe_cap.bin")).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0x10;
    std::fs::write(dir.join("lobe_cap.bin"), &bytes).unwrap();
    let err = MathTables::load(&gpu, &dir, &[MathTable::LobeCap]).err().expect("corrupt");
    assert!(matches!(err, TablesError::File { .. }), "{err}");
    assert!(err.to_string().contains("lobe_cap.bin") && err.to_string().contains("checksum"), "{err}");
    // A file holding another table under this name.
    std::fs::copy(default_dir().join("sh2_ol.bin"), dir.join("sh3_ol.bin")).unwrap();
    let err = MathTables::load(&gpu, &dir, &[MathTable::ShOl(3)]).err().expect("wrong name");
    assert!(matches!(err, TablesError::WrongName { .. }), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
    gpu.shutdown().expect("nothing leaked by the failed loads");
}
