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

/// One view rendered from a solution: selects the sources for `settings.method` (with
/// the view's camera; none for `direct` or without a solution), hands the selection
/// to `selected`, and renders. Records `select`, `render` and `reconstruct` in `t`.
#[allow(clippy::too_many_arguments)]
pub fn select_and_render<'a>(
    scene: &Scene,
    bvh: &Bvh,
    solution: Option<&'a Solution>,
    settings: &Settings,
    select: &SelectSettings,
    selected: &mut dyn FnMut(&Selection),
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
    let out = render::render(scene, bvh, settings, selection.as_ref(), progress)?;
    t.add("render", out.trace_s);
    t.add("reconstruct", out.reconstruct_s);
    Ok((out, selection))
}
