//! Experiments built from the passes: the paper's Tables 1-3 ([`tables`]) and the
//! performance benchmark ([`bench`]).

pub mod bench;
