//! The `.bpt` (Bezier patch) reader on any bytes, and the tessellation of what it
//! accepts: an error or patches, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(patches) = radtrace::geometry::bezier::parse_bpt(Path::new("fuzz.bpt"), data) {
        let mesh = radtrace::geometry::bezier::tessellate(&patches, 2, 2);
        assert!(mesh.validate().is_ok());
    }
});
