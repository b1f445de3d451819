//! The renderer's event counters (the paper's Tables 1-3 count these).
//!
//! Each rendering thread counts into its own [`Counters`]; they are summed at the end,
//! so counting costs no synchronisation. [`crate::stats`] turns them into tables and
//! the `--stats` JSON.

use std::ops::AddAssign;

use serde::Serialize;

/// Event counters. The names are the keys of the `--stats` JSON file.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct Counters {
    /// Camera rays traced.
    pub primary_rays: u64,
    /// Shadow (occlusion) rays cast towards light points.
    pub shadow_rays: u64,
    /// Hits on (partly) diffuse surfaces, where direct light is computed (paper Table 1).
    pub diffuse_hits: u64,
    /// Mirror reflection rays traced.
    pub reflection_rays: u64,
    /// Shadow rays not cast because the shadow image buffer's neighbours agreed.
    pub shadow_rays_saved: u64,
    /// Rays of the final gather (`--gather`, [`super::gather`]).
    pub gather_rays: u64,
    /// Gather records made at the screen's grid.
    pub gather_records: u64,
    /// Hits that took their gather from the records (the others gathered anew).
    pub gather_reused: u64,
    /// Anti-aliasing samples that took a nearby sample's light through their own
    /// texel: all of it (no shadow, gather or glossy ray), or its diffuse part.
    pub retextured: u64,
    /// Per ray-traced source (the scene's lights first, in order, then selected
    /// radiant patches): the diffuse hits that sampled it and the shadow rays cast.
    pub sources: Vec<SourceCount>,
}

/// Counts for one ray-traced source.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct SourceCount {
    /// Diffuse hits at which the source was sampled with shadow rays.
    pub hits: u64,
    /// Shadow rays cast towards it.
    pub shadow_rays: u64,
}

impl Counters {
    /// Zero counts for `sources` ray-traced sources.
    pub fn with_sources(sources: usize) -> Self {
        Counters {
            sources: vec![SourceCount::default(); sources],
            ..Default::default()
        }
    }

    /// One diffuse hit's sampling of source `source`: `cast` shadow rays cast and
    /// `saved` taken from the SIB's neighbours.
    pub fn count_source(&mut self, source: usize, cast: u64, saved: u64) {
        self.shadow_rays += cast;
        self.shadow_rays_saved += saved;
        if let Some(c) = self.sources.get_mut(source) {
            c.hits += 1;
            c.shadow_rays += cast;
        }
    }

    /// Shadow rays per diffuse hit (0 without hits).
    pub fn rays_per_hit(&self) -> f64 {
        if self.diffuse_hits > 0 {
            self.shadow_rays as f64 / self.diffuse_hits as f64
        } else {
            0.0
        }
    }
}

impl AddAssign for Counters {
    fn add_assign(&mut self, o: Self) {
        self.primary_rays += o.primary_rays;
        self.shadow_rays += o.shadow_rays;
        self.diffuse_hits += o.diffuse_hits;
        self.reflection_rays += o.reflection_rays;
        self.shadow_rays_saved += o.shadow_rays_saved;
        self.gather_rays += o.gather_rays;
        self.gather_records += o.gather_records;
        self.gather_reused += o.gather_reused;
        self.retextured += o.retextured;
        if self.sources.len() < o.sources.len() {
            self.sources.resize(o.sources.len(), SourceCount::default());
        }
        for (a, b) in self.sources.iter_mut().zip(o.sources) {
            a.hits += b.hits;
            a.shadow_rays += b.shadow_rays;
        }
    }
}

/// Counts of one level of the adaptive sampler (the paper's Table 2).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct LevelStats {
    /// The level (-1, 0, 1, ...).
    pub level: i32,
    /// Samples (primary rays) taken at this level.
    pub samples: u64,
    /// Diffuse hits, of the primary rays and of their reflections.
    pub diffuse_hits: u64,
    /// Shadow rays cast.
    pub shadow_rays: u64,
    /// Shadow rays not cast because the SIB's neighbours agreed.
    pub shadow_rays_saved: u64,
}
