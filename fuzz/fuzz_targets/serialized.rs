//! The serialized-mesh reader on any bytes: an error or a valid mesh, never a
//! panic, a hang or an allocation beyond what the (decompressed) data holds.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(mesh) = radtrace::geometry::serialized::parse_serialized(Path::new("fuzz.serialized"), data, 0, false) {
        assert!(mesh.validate().is_ok());
    }
});
