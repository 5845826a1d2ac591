//! PrusaSlicer slices what surfc writes for printing: the 3MF and the STL of a CAD part
//! (`examples/plate.surf`) and of the torus (`examples/torus.surf`'s `torus` block), with
//! Debian's `prusa-slicer` on the command line (`--export-gcode`; it needs no display). Its
//! 3MF reader is miniz's zip reader and its own model reader: surfc's 3MF once carried zip64
//! records that miniz refused ("Archive does not contain a valid model"). The G-code's top
//! layer must be the part's height, so the units and the geometry arrive as meant.
//!
//! Without `prusa-slicer` on the PATH the test says so on stderr and passes, unless
//! `SURFC_REQUIRE_SLICER=1` (as `.ci/run` sets, after installing it), under which it fails.

use std::io::Write as _;
use std::path::Path;
use std::process::Command;

use surfc::mesh::write::{Format, write_mesh_file};
use surfc::pipeline::Meshed;

use crate::parts;

/// The slicer's command, if it runs here; fails when it must and does not.
fn slicer() -> Option<&'static str> {
    const SLICER: &str = "prusa-slicer";
    let runs = Command::new(SLICER)
        .arg("--help")
        .output()
        .is_ok_and(|o| o.status.success());
    if runs {
        return Some(SLICER);
    }
    let required = std::env::var("SURFC_REQUIRE_SLICER").is_ok_and(|v| v == "1");
    assert!(
        !required,
        "SURFC_REQUIRE_SLICER=1 but `{SLICER}` does not run (apt-get install prusa-slicer)"
    );
    // Straight to the stderr handle: libtest captures `eprintln!` of passing tests.
    let _ = writeln!(
        std::io::stderr(),
        "\n*** SKIPPED: `{SLICER}` is not installed; surfc's 3MF and STL are NOT checked by a \
         slicer. `apt-get install prusa-slicer` (or run .ci/run) to check them. ***\n"
    );
    None
}

/// The Z of the G-code's layers (PrusaSlicer writes `;Z:` at each layer change).
fn layers(gcode: &str) -> Vec<f64> {
    gcode
        .lines()
        .filter_map(|l| l.strip_prefix(";Z:"))
        .filter_map(|z| z.trim().parse().ok())
        .collect()
}

/// Slices `meshed` written as `format` in layers of 0.1 mm and checks the G-code: layers
/// from the bed up to the part's height (within a layer).
fn slices(slicer: &str, dir: &Path, name: &str, meshed: &[Meshed], format: Format) {
    let path = dir.join(format!("{name}.{}", format.extension()));
    write_mesh_file(&path, format, &parts::named(meshed)).expect("written");
    let gcode = dir.join(format!("{name}-{}.gcode", format.extension()));
    let out = Command::new(slicer)
        .arg("--export-gcode")
        .arg(&path)
        .args(["--layer-height", "0.1", "--first-layer-height", "0.1"])
        .arg("--output")
        .arg(&gcode)
        .output()
        .expect("the slicer runs");
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.status.success(),
        "{slicer} could not slice {}:\n{said}",
        path.display()
    );
    let text = std::fs::read_to_string(&gcode).expect("the G-code");
    let z = layers(&text);
    assert!(z.len() >= 2, "{name}.{format}: layers {z:?}\n{said}");
    let (lo, hi) = meshed
        .iter()
        .flat_map(|m| &m.mesh.vertices)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v.z), hi.max(v.z))
        });
    let top = z.iter().copied().fold(0.0, f64::max);
    let height = hi - lo;
    // Layers of 0.1 mm: the top layer lies within one of the part's height, which in
    // millimetres is the model's own (the 3MF says millimeter; the STL's numbers are read so).
    assert!(
        (top - height).abs() <= 0.1 + 1e-9,
        "{name}.{format}: top layer at {top} mm, the part is {height} high"
    );
}

#[test]
fn prusa_slicer_slices_the_3mf_and_stl_of_a_part_and_the_torus() {
    let Some(slicer) = slicer() else {
        return;
    };
    let dir = tempfile::tempdir().expect("a temporary directory");
    for (name, meshed) in [("plate", parts::plate()), ("torus", parts::torus())] {
        for format in [Format::ThreeMf, Format::Stl] {
            slices(slicer, dir.path(), name, meshed, format);
        }
    }
}
