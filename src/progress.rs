//! How long-running work (the solve, the levels of a render) reports how far it got.
//!
//! The core only calls this trait; the command line draws it with indicatif
//! ([`crate::cli`]), and library users who want nothing pass [`Silent`].

/// A receiver of progress reports, one stage at a time. Called from worker threads.
pub trait Progress: Sync {
    /// A stage named `label` with `total` units of work begins.
    fn start(&self, label: &str, total: u64);
    /// `units` more units of the current stage are done.
    fn advance(&self, units: u64);
    /// `done` units of the current stage are done in all (for work whose amount
    /// left is re-estimated, such as the solve's shot fraction of power).
    fn set(&self, done: u64);
    /// The current stage is over.
    fn finish(&self);
}

/// Reports nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Progress for Silent {
    fn start(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
    fn set(&self, _: u64) {}
    fn finish(&self) {}
}
