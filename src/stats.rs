//! Statistics: named counters of the paper's Tables 1-3 and pass timings.
//!
//! Each rendering thread counts into its own [`Counters`]; they are summed at the end,
//! so counting costs no synchronisation.

use std::collections::BTreeMap;

use serde::Serialize;

pub use crate::render::counters::{Counters, LevelStats, SourceCount};

mod json;
pub use json::*;

/// The fully sampled render another one is compared with (`--baseline`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Baseline {
    /// Its method (the row's label).
    pub method: String,
    /// Its diffuse hits.
    pub diffuse_hits: u64,
    /// Its shadow rays.
    pub shadow_rays: u64,
}

/// Percentage of `baseline`'s shadow rays that `rays` saves.
pub fn percent_saved(rays: u64, baseline: u64) -> f64 {
    if baseline == 0 {
        0.0
    } else {
        100.0 * (1.0 - rays as f64 / baseline as f64)
    }
}

/// The counts as a text table in the layout of the paper's Table 1: one row for the
/// baseline (if any) and one for this render (`method`), then the shadow rays per
/// source (`names`: name and kind of each entry of `c.sources`).
pub fn table1(
    title: &str,
    method: &str,
    c: &Counters,
    names: &[(String, String)],
    baseline: Option<&Baseline>,
) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(out, "Table 1. Diffuse hits and shadow rays: {title}");
    let _ = writeln!(
        out,
        "{:<10} {:>20} {:>20} {:>20} {:>20}",
        "method", "No. of diffuse hits", "No. of shadow rays", "Shadow rays per hit", "% Shadow rays saved"
    );
    let row = |out: &mut String, label: &str, hits: u64, rays: u64, saved: Option<f64>| {
        let per = if hits > 0 { rays as f64 / hits as f64 } else { 0.0 };
        let saved = saved.map(|s| format!("{s:.0}")).unwrap_or_else(|| "-".into());
        let _ = writeln!(out, "{label:<10} {hits:>20} {rays:>20} {per:>20.1} {saved:>20}");
    };
    if let Some(b) = baseline {
        row(&mut out, &b.method, b.diffuse_hits, b.shadow_rays, Some(0.0));
    }
    row(
        &mut out,
        method,
        c.diffuse_hits,
        c.shadow_rays,
        baseline.map(|b| percent_saved(c.shadow_rays, b.shadow_rays)),
    );
    let _ = writeln!(out);
    let _ = writeln!(
        out,
        "{:<32} {:>6} {:>16} {:>20} {:>20}",
        format!("per source ({method})"),
        "kind",
        "hits sampled",
        "No. of shadow rays",
        "Shadow rays per hit"
    );
    let mut patches = SourceCount::default();
    let mut patch_count = 0;
    for (s, (name, kind)) in c.sources.iter().zip(names) {
        if kind == "patch" {
            patches.hits += s.hits;
            patches.shadow_rays += s.shadow_rays;
            patch_count += 1;
            continue;
        }
        let per = if c.diffuse_hits > 0 {
            s.shadow_rays as f64 / c.diffuse_hits as f64
        } else {
            0.0
        };
        let _ = writeln!(
            out,
            "{name:<32} {kind:>6} {:>16} {:>20} {per:>20.2}",
            s.hits, s.shadow_rays
        );
    }
    if patch_count > 0 {
        let per = if c.diffuse_hits > 0 {
            patches.shadow_rays as f64 / c.diffuse_hits as f64
        } else {
            0.0
        };
        let _ = writeln!(
            out,
            "{:<32} {:>6} {:>16} {:>20} {per:>20.2}",
            format!("{patch_count} radiant patches"),
            "patch",
            patches.hits,
            patches.shadow_rays
        );
    }
    if c.gather_rays > 0 {
        let _ = writeln!(out);
        let _ = writeln!(
            out,
            "final gather: {} rays, {} records; {} of {} diffuse hits served by the records ({:.0} %)",
            c.gather_rays,
            c.gather_records,
            c.gather_reused,
            c.diffuse_hits,
            percent_of(
                c.gather_reused,
                c.diffuse_hits - c.gather_reused.min(c.diffuse_hits)
            ),
        );
    }
    out
}

/// Percentage of `saved` in `saved + cast` (0 when both are 0).
fn percent_of(saved: u64, cast: u64) -> f64 {
    if saved + cast == 0 {
        0.0
    } else {
        100.0 * saved as f64 / (saved + cast) as f64
    }
}

/// One level of the paper's Table 2, with the percentages of rays saved.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LevelFigures {
    /// The level (-1, 0, 1, ...).
    pub level: i32,
    /// Diffuse hits at the level.
    pub diffuse_hits: u64,
    /// Shadow rays cast at the level.
    pub shadow_rays: u64,
    /// Shadow rays the SIB saved at the level.
    pub shadow_rays_saved: u64,
    /// % of the level's shadow rays saved.
    pub saved_percent: f64,
    /// % saved over the levels so far.
    pub saved_cumulative_percent: f64,
}

/// The paper's Table 2 figures for one render: per level, diffuse hits, shadow rays,
/// shadow rays saved, % saved at the level and % saved cumulatively (levels so far).
pub fn table2_figures(levels: &[LevelStats]) -> Vec<LevelFigures> {
    let (mut saved, mut cast) = (0u64, 0u64);
    levels
        .iter()
        .map(|l| {
            saved += l.shadow_rays_saved;
            cast += l.shadow_rays;
            LevelFigures {
                level: l.level,
                diffuse_hits: l.diffuse_hits,
                shadow_rays: l.shadow_rays,
                shadow_rays_saved: l.shadow_rays_saved,
                saved_percent: percent_of(l.shadow_rays_saved, l.shadow_rays),
                saved_cumulative_percent: percent_of(saved, cast),
            }
        })
        .collect()
}

/// [`table2_figures`] as text cells.
pub fn table2_rows(levels: &[LevelStats]) -> Vec<[String; 6]> {
    table2_figures(levels)
        .into_iter()
        .map(|f| {
            [
                f.level.to_string(),
                f.diffuse_hits.to_string(),
                f.shadow_rays.to_string(),
                f.shadow_rays_saved.to_string(),
                format!("{:.0}", f.saved_percent),
                format!("{:.0}", f.saved_cumulative_percent),
            ]
        })
        .collect()
}

/// The column headers of the paper's Table 2 (the first, "Figure", only in
/// `radtrace tables`).
pub const TABLE2_HEADERS: [&str; 7] = [
    "Figure",
    "Level",
    "No. of diffuse hits",
    "No. of shadow rays",
    "No. of shadow rays saved",
    "% Shadow rays saved",
    "% Shadow rays saved cumulatively",
];

/// A text table: `title`, then the column headers and rows, each column as wide as
/// its widest cell; the first column left-aligned, the others right-aligned.
pub fn format_table(title: &str, headers: &[&str], rows: &[Vec<String>]) -> String {
    use std::fmt::Write;
    let mut width: Vec<usize> = headers.iter().map(|h| h.len()).collect();
    for r in rows {
        for (k, c) in r.iter().enumerate() {
            if k < width.len() {
                width[k] = width[k].max(c.len());
            }
        }
    }
    let line = |cells: &mut dyn Iterator<Item = &str>| {
        let mut out = String::new();
        for (k, c) in cells.enumerate() {
            if k == 0 {
                let _ = write!(out, "{c:<w$}", w = width[0]);
            } else {
                let _ = write!(out, "  {c:>w$}", w = width[k]);
            }
        }
        out.trim_end().to_string()
    };
    let mut out = format!("{title}\n");
    out += &line(&mut headers.iter().copied());
    out.push('\n');
    for r in rows {
        out += &line(&mut r.iter().map(String::as_str));
        out.push('\n');
    }
    out
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
    fn counters_add_field_by_field_and_source_by_source() {
        let src = |hits, shadow_rays| SourceCount { hits, shadow_rays };
        let mut a = Counters {
            primary_rays: 1,
            shadow_rays: 2,
            diffuse_hits: 3,
            reflection_rays: 4,
            shadow_rays_saved: 5,
            gather_rays: 7,
            gather_records: 8,
            gather_reused: 9,
            retextured: 6,
            sources: vec![src(1, 2)],
        };
        a += Counters {
            primary_rays: 10,
            shadow_rays: 20,
            diffuse_hits: 30,
            reflection_rays: 40,
            shadow_rays_saved: 50,
            gather_rays: 70,
            gather_records: 80,
            gather_reused: 90,
            retextured: 60,
            sources: vec![src(10, 20), src(5, 6)],
        };
        assert_eq!(
            a,
            Counters {
                primary_rays: 11,
                shadow_rays: 22,
                diffuse_hits: 33,
                reflection_rays: 44,
                shadow_rays_saved: 55,
                gather_rays: 77,
                gather_records: 88,
                gather_reused: 99,
                retextured: 66,
                sources: vec![src(11, 22), src(5, 6)],
            }
        );
        assert_eq!(a.rays_per_hit(), 22.0 / 33.0);
        assert_eq!(Counters::default().rays_per_hit(), 0.0);
    }

    #[test]
    fn table1_shows_the_papers_columns_and_the_rays_saved() {
        let c = Counters {
            diffuse_hits: 414_089,
            shadow_rays: 19_179_896,
            sources: vec![
                SourceCount {
                    hits: 10,
                    shadow_rays: 19_000_000,
                },
                SourceCount {
                    hits: 3,
                    shadow_rays: 179_000,
                },
                SourceCount {
                    hits: 1,
                    shadow_rays: 896,
                },
            ],
            ..Default::default()
        };
        let names = [
            ("A".into(), "spot".into()),
            ("p1".into(), "patch".into()),
            ("p2".into(), "patch".into()),
        ];
        let base = Baseline {
            method: "norm".into(),
            diffuse_hits: 414_326,
            shadow_rays: 41_708_468,
        };
        let t = table1("room", "local", &c, &names, Some(&base));
        // The paper's Table 1, Fig. 8a vs 9a: 54 % saved.
        assert!(t.contains("% Shadow rays saved"));
        let local = t.lines().find(|l| l.starts_with("local")).unwrap();
        let cols: Vec<&str> = local.split_whitespace().collect();
        assert_eq!(cols, ["local", "414089", "19179896", "46.3", "54"]);
        let norm = t.lines().find(|l| l.starts_with("norm")).unwrap();
        assert!(norm
            .split_whitespace()
            .eq(["norm", "414326", "41708468", "100.7", "0"]));
        // Radiant patches are summed in one row.
        assert!(t.contains("2 radiant patches"), "{t}");
        assert!(
            t.lines().any(|l| l.split_whitespace().collect::<Vec<_>>()
                == ["2", "radiant", "patches", "patch", "4", "179896", "0.43"]),
            "{t}"
        );
        // Without a baseline, nothing is claimed saved.
        let t = table1("room", "local", &c, &names, None);
        assert!(t
            .lines()
            .any(|l| l.starts_with("local") && l.trim_end().ends_with('-')));
        // No gather, no gather line; with one, its rays, records and reuse.
        assert!(!t.contains("final gather"), "{t}");
        let g = Counters {
            gather_rays: 1_509_564,
            gather_records: 16_384,
            gather_reused: 310_567,
            ..c
        };
        let t = table1("room", "local", &g, &names, None);
        assert!(
            t.lines().any(|l| l
                == "final gather: 1509564 rays, 16384 records; 310567 of 414089 diffuse hits served by the records (75 %)"),
            "{t}"
        );
    }

    #[test]
    fn table2_reproduces_the_papers_percentages() {
        // The paper's Table 2, Fig. 8a: levels -1..2.
        let l = |level, diffuse_hits, shadow_rays, shadow_rays_saved| LevelStats {
            level,
            samples: 0,
            diffuse_hits,
            shadow_rays,
            shadow_rays_saved,
        };
        let levels = [
            l(-1, 65795, 6_908_657, 0),
            l(0, 196_549, 3_022_652, 17_669_301),
            l(1, 61001, 4_718_431, 1_368_025),
            l(2, 131_844, 9_710_946, 2_971_650),
        ];
        let rows = table2_rows(&levels);
        let pct: Vec<(&str, &str)> = rows.iter().map(|r| (r[4].as_str(), r[5].as_str())).collect();
        assert_eq!(pct, [("0", "0"), ("85", "64"), ("22", "57"), ("23", "47")]);
        let t = format_table(
            "Table 2",
            &["Figure", "Level", "No. of diffuse hits"],
            &[vec!["8a".into(), "-1".into(), "65795".into()]],
        );
        assert_eq!(
            t,
            "Table 2\nFigure  Level  No. of diffuse hits\n8a         -1                65795\n"
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
