//! The PLY reader (ASCII and binary) on any bytes: an error or a valid mesh, never a
//! panic, a hang or an allocation beyond the file's size.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(mesh) = radtrace::geometry::ply::parse_ply(Path::new("fuzz.ply"), data, false) {
        assert!(mesh.validate().is_ok());
    }
});
