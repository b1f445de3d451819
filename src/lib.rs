//! radtrace: radiosity ray tracing with source selection and a shadow image buffer.
//!
//! An implementation of Kok, Jansen & Woodward, "Efficient, complete radiosity ray
//! tracing using a shadow-coherence method", The Visual Computer 10:19-33 (1993).
//!
//! Data flows one way, as in the paper:
//! [`scene`] (loaded from a Mitsuba 3 XML file) -> [`accel`] (BVH) and [`mesh`] ->
//! [`radiosity`] (pass 1, the view-independent solution) -> [`selection`] (which
//! sources are ray traced where) -> [`render`] (pass 2: image + [`stats`]) -> [`io`]
//! (EXR/PNG/JSON, solution files).
#![forbid(unsafe_code)]
// `!(x > 0.0)` is used on purpose: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod bench;
pub mod cli;
pub mod compare;
pub mod error;
pub mod geometry;
pub mod io;
pub mod mesh;
pub mod radiosity;
pub mod render;
pub mod scene;
pub mod selection;
pub mod stats;
#[cfg(test)]
pub(crate) mod testutil;

pub use error::{Error, Result};
