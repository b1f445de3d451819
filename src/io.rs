//! Images in and out: OpenEXR (linear radiance) and PNG (sRGB, 8 bit).

use std::path::Path;

use glam::Vec3;

use crate::Result;

/// A linear RGB image, row-major from the top-left.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` pixels.
    pub pixels: Vec<Vec3>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Image {
            width,
            height,
            pixels: vec![Vec3::ZERO; (width * height) as usize],
        }
    }
}

/// Writes `img` as `.exr` (linear, 32-bit float) or `.png` (sRGB 8-bit, scaled by
/// `2^exposure`) according to the extension. Writes to a temporary file beside
/// `path` and renames it, so an interrupted run leaves no partial file.
pub fn write_image(_img: &Image, _path: &Path, _exposure: f32) -> Result<()> {
    todo!("helper: io")
}

/// Reads an `.exr` (or `.png`, converted to linear) image.
pub fn read_image(_path: &Path) -> Result<Image> {
    todo!("helper: io")
}

/// Writes `text` to `path` through a temporary file and a rename.
pub fn write_atomic(_path: &Path, _bytes: &[u8]) -> Result<()> {
    todo!("helper: io")
}
