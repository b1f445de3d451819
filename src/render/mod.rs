//! The rendering pass: camera, shading and image reconstruction.
