//! `radtrace compare`.

use serde_json::json;

use super::args::CompareArgs;
use crate::Result;

pub(super) fn cmd_compare(a: CompareArgs) -> Result<()> {
    let c = crate::compare::compare_files(&a.reference, &a.test, a.error_map.as_deref())?;
    if a.json {
        say!(
            "{}",
            json!({ "reference": a.reference, "test": a.test, "flip": c.flip, "rmse": c.rmse })
        );
    } else {
        say!("mean FLIP {:.4}  RMSE {:.5}", c.flip, c.rmse);
    }
    Ok(())
}
