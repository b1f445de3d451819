//! Statistics: named counters of the paper's Tables 1-3 and pass timings.
//!
//! Each rendering thread counts into its own [`Counters`]; they are summed at the end,
//! so counting costs no synchronisation.

use std::collections::BTreeMap;
use std::ops::AddAssign;

use serde::Serialize;

/// Event counters. The names are the keys of the `--stats` JSON file.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Counters {
    /// Camera rays traced.
    pub primary_rays: u64,
    /// Shadow (occlusion) rays cast towards light points.
    pub shadow_rays: u64,
    /// Hits on (partly) diffuse surfaces, where direct light is computed (paper Table 1).
    pub diffuse_hits: u64,
    /// Mirror reflection rays traced.
    pub reflection_rays: u64,
}

impl AddAssign for Counters {
    fn add_assign(&mut self, o: Self) {
        self.primary_rays += o.primary_rays;
        self.shadow_rays += o.shadow_rays;
        self.diffuse_hits += o.diffuse_hits;
        self.reflection_rays += o.reflection_rays;
    }
}

/// Wall-clock seconds per pass, in the order the passes ran; `total` is added on output.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Timings {
    passes: Vec<(String, f64)>,
}

impl Timings {
    /// Records `seconds` for `pass` (adding to it if it ran before).
    pub fn add(&mut self, pass: &str, seconds: f64) {
        match self.passes.iter_mut().find(|(p, _)| p == pass) {
            Some((_, s)) => *s += seconds,
            None => self.passes.push((pass.to_string(), seconds)),
        }
    }

    /// Runs `f`, recording its wall time under `pass`.
    pub fn time<T>(&mut self, pass: &str, f: impl FnOnce() -> T) -> T {
        let start = std::time::Instant::now();
        let out = f();
        self.add(pass, start.elapsed().as_secs_f64());
        out
    }

    /// Seconds of `pass`, if it ran.
    pub fn get(&self, pass: &str) -> Option<f64> {
        self.passes.iter().find(|(p, _)| p == pass).map(|(_, s)| *s)
    }

    /// The JSON object `{"total": ..., "<pass>": ...}`.
    pub fn to_json(&self, total: f64) -> BTreeMap<String, f64> {
        let mut m: BTreeMap<String, f64> = self.passes.iter().cloned().collect();
        m.insert("total".into(), total);
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counters_add_field_by_field() {
        let mut a = Counters {
            primary_rays: 1,
            shadow_rays: 2,
            diffuse_hits: 3,
            reflection_rays: 4,
        };
        a += Counters {
            primary_rays: 10,
            shadow_rays: 20,
            diffuse_hits: 30,
            reflection_rays: 40,
        };
        assert_eq!(
            a,
            Counters {
                primary_rays: 11,
                shadow_rays: 22,
                diffuse_hits: 33,
                reflection_rays: 44
            }
        );
    }

    #[test]
    fn timings_accumulate_and_report_total() {
        let mut t = Timings::default();
        t.add("load", 0.5);
        t.add("render", 2.0);
        t.add("load", 0.25);
        let j = t.to_json(3.0);
        assert_eq!(j["load"], 0.75);
        assert_eq!(j["render"], 2.0);
        assert_eq!(j["total"], 3.0);
        assert_eq!(t.get("missing"), None);
    }
}
