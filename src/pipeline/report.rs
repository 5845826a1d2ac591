//! The report of one meshed block as `surfc mesh --json` prints it in `{"meshes": […]}`
//! (docs/cli.md): the block's name, surface and step, its topology and quality figures, the
//! largest chord error, warnings, orientation, creases, pieces and time. The command line,
//! `surfc watch --json` and the Python package all give this one form.

use serde::Serialize;

use super::Meshed;
use super::creased::CreaseCounts;
use crate::mesh::quality::MeshReport;

/// One mesh of the `--json` report (docs/cli.md); the fields keep the documented order.
#[derive(Clone, Debug, Serialize)]
pub struct BlockJson<'a> {
    pub name: &'a str,
    pub surface: &'a str,
    pub step: f64,
    #[serde(flatten)]
    pub report: MeshReport,
    pub max_chord_error: f64,
    pub warnings: &'a [String],
    /// Whether the mesh was flipped against its ∇f to agree with the net it joins.
    pub flipped: bool,
    /// The creases of a mesh made crease by crease, else null.
    pub creases: Option<CreaseCounts>,
    /// Slabs marched on separate threads (`pipeline::pieces`); left out when 1.
    #[serde(skip_serializing_if = "is_one")]
    pub pieces: usize,
    pub seconds: f64,
}

fn is_one(n: &usize) -> bool {
    *n == 1
}

impl Meshed {
    /// The block's entry of the `--json` report.
    pub fn json(&self) -> BlockJson<'_> {
        BlockJson {
            name: &self.name,
            surface: &self.surface,
            step: self.step,
            report: self.report.clone(),
            max_chord_error: self.max_chord_error,
            warnings: &self.warnings,
            flipped: self.flipped,
            creases: self.creases,
            pieces: self.pieces,
            seconds: self.seconds,
        }
    }

    /// The block's entry of the `--json` report as JSON text (one object, one line).
    pub fn json_text(&self) -> String {
        // Serialising plain numbers, strings and lists cannot fail; a non-finite number
        // becomes null, as in `--json`.
        serde_json::to_string(&self.json()).unwrap_or_default()
    }
}
