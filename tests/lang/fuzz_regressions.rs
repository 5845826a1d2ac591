//! Inputs the fuzzers of `fuzz/` found failing (docs/fuzzing.md), each kept as it was found
//! (`tests/fixtures/fuzz/`) with the property its target checks, so the fix stays fixed.

use std::path::Path;

use surfc::eval::Engine;
use surfc::pipeline::mesh_checked;
use surfc::{diag, sema, syntax};

fn fixture(name: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/fuzz")
        .join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn parse(text: &str) -> syntax::ast::File {
    match syntax::parse(text) {
        (Some(file), _) => file,
        (None, diags) => panic!("does not parse: {diags:?}\n{text}"),
    }
}

/// `parse_check_fmt`'s property: `fmt` keeps the AST and the comments, and is idempotent.
fn assert_formats_stably(text: &str) -> String {
    let file = parse(text);
    let once = syntax::format(&file);
    let again = parse(&once);
    assert_eq!(
        syntax::sexpr(&file),
        syntax::sexpr(&again),
        "fmt changed the AST\n{once}"
    );
    let comments = |f: &syntax::ast::File| -> Vec<String> {
        f.comments.iter().map(|c| c.text.clone()).collect()
    };
    assert_eq!(
        comments(&file),
        comments(&again),
        "fmt changed the comments"
    );
    assert_eq!(once, syntax::format(&again), "fmt is not idempotent");
    once
}

/// parse_check_fmt, 2026-11-30: a comment written inside a mesh block's surface expression
/// moves before the block, after a comment that a blank line separated from the block. The
/// first `fmt` kept that blank line (the block's own), the second dropped it (it was now
/// between two leading comments, where blank lines were ignored).
#[test]
fn a_blank_line_between_leading_comments_survives_a_second_fmt() {
    assert_formats_stably(&fixture("fmt_blank_line_between_comments.surf"));
    let minimal = "// a\n\nmesh m = s - //x\n 1 { step: 0.1; }\n";
    assert_eq!(
        assert_formats_stably(minimal),
        "// a\n\n//x\nmesh m = s - 1 {\n    step: 0.1;\n}\n"
    );
    // Blank lines between comments are kept (at most one) wherever they were written.
    let spaced = "// a\n\n\n// b\nsurface s = x;\n\n// c\n\n// d\n";
    assert_eq!(
        assert_formats_stably(spaced),
        "// a\n\n// b\nsurface s = x;\n\n// c\n\n// d\n"
    );
}

/// mesh_small, 2026-11-30: a thin sheet in a box 2.5·10¹⁴ long, meshed as the fuzz target
/// does (interpreter, `max_triangles` capped at 2000), ran past libFuzzer's 60 s: the
/// component search's octree walked the whole box before any march could hit the limit.
/// The search is now bounded by `max_triangles`; the block must fail (its surface in the
/// box is far larger than 2000 triangles) with the triangle-limit diagnostic. Both surfaces
/// have a cusp along the z axis (`x^4 + y^k = 0`); where the search seeds a component next to
/// it (the first file) the start check refuses it there, with where, before any march.
#[test]
fn a_sheet_in_a_huge_box_stops_at_the_triangle_limit() {
    for (name, reason) in [
        ("long_thin_box.surf", "does not change sign"),
        ("long_thin_box_slow.surf", "2000"),
    ] {
        let text = fixture(name);
        let file = parse(&text);
        let (mut program, diags) = sema::check(&file);
        assert!(!diag::has_errors(&diags), "{name}: {diags:?}");
        for m in &mut program.meshes {
            m.max_triangles = Some(2000);
        }
        let started = std::time::Instant::now();
        let failure = match mesh_checked(&program, &text, Engine::Interpreter) {
            Ok(_) => panic!("{name}: a sheet 2.5e14 long meshed in 2000 triangles"),
            Err(d) => d,
        };
        assert_eq!(failure.code, "E0601", "{name}: {failure:?}");
        let said = format!("{} {:?}", failure.message, failure.notes);
        assert!(
            said.contains(reason),
            "{name}: the diagnostic does not say {reason:?}: {said}"
        );
        // Generous against a loaded machine; the run it replaces never ended within 60 s.
        assert!(
            started.elapsed().as_secs() < 20,
            "{name}: {:?}",
            started.elapsed()
        );
    }
}
