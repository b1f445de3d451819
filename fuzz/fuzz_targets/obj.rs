//! The OBJ reader on any bytes: an error or a valid mesh, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    for face_normals in [false, true] {
        if let Ok(mesh) = radtrace::geometry::obj::parse_obj(Path::new("fuzz.obj"), data, face_normals) {
            assert!(mesh.validate().is_ok());
        }
    }
});
