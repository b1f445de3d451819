//! Image comparison: mean FLIP (NVIDIA's perceptual metric, LDR) and RMSE.

use crate::io::Image;
use crate::Result;

/// The result of comparing two images.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Comparison {
    /// Mean LDR FLIP error of the sRGB-clipped images (0 = identical).
    pub flip: f32,
    /// Root mean square error of the linear radiance, over all channels.
    pub rmse: f32,
}

/// Compares `test` against `reference`; the images must have the same size.
/// With `error_map`, also returns the FLIP error map coloured with the magma map.
pub fn compare(_reference: &Image, _test: &Image, _error_map: bool) -> Result<(Comparison, Option<Image>)> {
    todo!("helper: io")
}

/// Reads both images, compares them, and writes the error map if asked.
pub fn compare_files(
    _reference: &std::path::Path,
    _test: &std::path::Path,
    _error_map: Option<&std::path::Path>,
) -> Result<Comparison> {
    todo!("helper: io")
}
