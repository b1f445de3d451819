//! radtrace: radiosity ray tracing with source selection and a shadow image buffer.
//!
//! An implementation of Kok, Jansen & Woodward, "Efficient, complete radiosity ray
//! tracing using a shadow-coherence method", The Visual Computer 10:19-33 (1993).
//!
//! The modules are layers that run one way: a module imports only from its own
//! place in this list or from above it (`tests/layers.rs` checks it).
//!
//! 1. Shared ground: [`error`], [`progress`] (how long work reports itself),
//!    [`sampling`] (the one seed and hash scheme), [`image`] (pixels, sRGB),
//!    [`geometry`] (triangle meshes, Bezier patches, OBJ/PLY), [`scene`] (the Mitsuba
//!    3 reader), [`accel`] (the BVH: rays and hits).
//! 2. Shared concepts of both passes: [`bsdf`] (evaluation, albedo), [`emitters`]
//!    (light points, sub-sources, power), [`interaction`] (the hit frame and the one
//!    rule for rays leaving a surface), [`camera`].
//! 3. The method, in the order data flows: [`mesh`] -> [`radiosity`] (pass 1) ->
//!    [`selection`] -> [`render`] (pass 2: sampler, SIB, film, debug pictures).
//! 4. Around the method: [`io`] (files), [`stats`] (tables, JSON), [`compare`] (FLIP),
//!    [`experiments`] (the paper's tables, benchmarks), [`cli`] (the only user of
//!    clap and indicatif).
#![forbid(unsafe_code)]
// `!(x > 0.0)` is used on purpose: unlike `x <= 0.0` it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod error;
pub mod geometry;
pub mod image;
pub mod progress;
pub mod sampling;
pub mod scene;

pub mod bsdf;
pub mod camera;
pub mod emitters;
pub mod interaction;

pub mod mesh;
pub mod radiosity;
pub mod render;
pub mod selection;

pub mod cli;
pub mod compare;
pub mod experiments;
pub mod io;
pub mod stats;

#[cfg(test)]
pub(crate) mod testutil;

pub use error::{Error, Result};
