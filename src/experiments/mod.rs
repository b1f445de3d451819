//! Experiments built from the passes: the paper's Tables 1-3 ([`tables`]) and the
//! performance benchmark ([`bench`]).

pub mod bench;
pub mod tables;

use crate::accel::Bvh;
use crate::camera::Camera;
use crate::progress::Progress;
use crate::radiosity::Solution;
use crate::render::{self, Method, Output, Settings};
use crate::scene::Scene;
use crate::selection::{self, SelectSettings, Selection, ViewScale};
use crate::stats::Timings;
use crate::Result;

/// A step of the progressive display: what it shows and its image.
pub type StepSink<'s> = &'s mut dyn FnMut(&str, &Output) -> Result<()>;

/// One view rendered from a solution: selects the sources for `settings.method` (with
/// the view's camera; none for `direct` or without a solution), hands the selection
/// to `selected`, and renders. Records `select`, `render` and `reconstruct` in `t`.
///
/// With `steps`, the paper's progressive display (Sect. 3) comes first: "initially,
/// the general radiosity term is displayed and, starting with the most important light
/// sources, their contribution is calculated more accurately with shadow ray tracing".
/// Each step is a preview of the same settings at one sample per pixel and without the
/// final gather: the solution alone, then the 1, 2, 4 ... strongest of the selected
/// sources ray traced (the others from the solution, [`Selection::only`]), then, with a
/// gather, all of them; each goes to `steps` as it is done. The render returned is the one without `steps`, so the
/// last image is the same.
#[allow(clippy::too_many_arguments)]
pub fn select_and_render<'a>(
    scene: &Scene,
    bvh: &Bvh,
    solution: Option<&'a Solution>,
    settings: &Settings,
    select: &SelectSettings,
    selected: &mut dyn FnMut(&Selection),
    steps: Option<StepSink>,
    progress: &dyn Progress,
    t: &mut Timings,
) -> Result<(Output, Option<Selection<'a>>)> {
    let sensor = scene.sensor(settings.view)?;
    let camera = Camera::new(sensor, settings.width, settings.height);
    let selection = match (solution, settings.method) {
        (_, Method::Direct) | (None, _) => None,
        (Some(sol), method) => {
            let view = ViewScale::of(&camera);
            Some(t.time("select", || {
                selection::select(scene, sol, method, select, Some(&view))
            })?)
        }
    };
    if let Some(sel) = &selection {
        selected(sel);
    }
    if let (Some(sink), Some(full)) = (steps, &selection) {
        // Steps before the last are previews: one sample per pixel (the adaptive
        // sampler's level 0, or one uniform sample), no gather.
        let mut step = Settings {
            gather: 0,
            spp: 1,
            ..settings.clone()
        };
        step.refine.max_level = 0;
        let ranked = full.ranked(scene);
        let n = ranked.len();
        // Sources ray traced at each step: none, 1, 2, 4 ... below all; all too when
        // the final render adds a gather (without one it is the final render).
        let mut counts = vec![0];
        let mut k = 1;
        while k < n {
            counts.push(k);
            k *= 2;
        }
        if settings.gather > 0 && n > 0 {
            counts.push(n);
        }
        if n == 0 && settings.gather == 0 {
            counts.clear();
        }
        for k in counts {
            let out = render::render(scene, bvh, &step, Some(&full.only(&ranked[..k])), progress)?;
            t.add("render", out.trace_s);
            t.add("reconstruct", out.reconstruct_s);
            let label = match k {
                0 => "the radiosity solution alone".to_string(),
                k if k == n => format!("all {n} selected sources ray traced"),
                k => format!("the {k} strongest of {n} selected sources ray traced"),
            };
            sink(&label, &out)?;
        }
    }
    let out = render::render(scene, bvh, settings, selection.as_ref(), progress)?;
    t.add("render", out.trace_s);
    t.add("reconstruct", out.reconstruct_s);
    Ok((out, selection))
}
