//! `radtrace tessellate`.

use super::args::TessellateArgs;
use super::check_output_ext;
use crate::{Error, Result};

pub(super) fn cmd_tessellate(a: TessellateArgs) -> Result<()> {
    check_output_ext(&a.output, &["obj"])?;
    let patches = crate::geometry::bezier::read_bpt(&a.input)?;
    let tris = crate::geometry::bezier::tessellated_triangles(patches.len(), a.coarse, a.fine);
    if tris > crate::geometry::bezier::MAX_TESSELLATED_TRIANGLES {
        return Err(Error::Usage(format!(
            "--coarse {} --fine {}: {} patches would make {tris} triangles (at most {})",
            a.coarse,
            a.fine,
            patches.len(),
            crate::geometry::bezier::MAX_TESSELLATED_TRIANGLES
        )));
    }
    let mesh = crate::geometry::bezier::tessellate(&patches, a.coarse, a.fine);
    crate::io::write_obj(&mesh, &a.output)?;
    eprintln!(
        "radtrace: {} Bezier patches -> {} triangles, {} vertices -> {}",
        patches.len(),
        mesh.triangle_count(),
        mesh.positions.len(),
        a.output.display()
    );
    Ok(())
}
