//! Arbitrary bytes → a checked program → every mesh block meshed with at most
//! `MAX_TRIANGLES` triangles (run with libFuzzer's `-timeout` as the time budget): never a
//! panic, never a hang; a mesh that comes back is one every writer accepts (finite
//! vertices, indices in range, one finite normal per vertex).
#![no_main]

use libfuzzer_sys::fuzz_target;
use surfc::pipeline::{mesh_checked, named};
use surfc::eval::Engine;
use surfc::mesh::write::{Format, validate};
use surfc::{diag, sema, syntax};

const MAX_TRIANGLES: u64 = 2000;
/// Inputs with more mesh blocks than this are skipped (each block costs up to the budget).
const MAX_BLOCKS: usize = 3;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = syntax::source_text(data) else {
        return;
    };
    let (Some(file), diags) = syntax::parse(text) else {
        return;
    };
    let (mut program, more) = sema::check(&file);
    if diag::has_errors(&diags) || diag::has_errors(&more) || program.meshes.len() > MAX_BLOCKS {
        return;
    }
    for m in &mut program.meshes {
        m.max_triangles = Some(m.max_triangles.unwrap_or(MAX_TRIANGLES).min(MAX_TRIANGLES));
    }
    // The interpreter: no machine code compiled per input, so more inputs a second.
    if let Ok(meshed) = mesh_checked(&program, text, Engine::Interpreter) {
        let meshes = named(&meshed);
        for format in Format::ALL {
            if let Err(e) = validate(&meshes, format) {
                panic!("a finished mesh that {format} cannot write: {e}\n{text}");
            }
        }
    }
});
