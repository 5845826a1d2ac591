//! Arbitrary bytes → parse → check → render the diagnostics → format → parse again: never a
//! panic; the formatted text parses to the same AST (span-free S-expressions), keeps the
//! comments, and formatting it again changes nothing.
#![no_main]

use libfuzzer_sys::fuzz_target;
use surfc::{diag, sema, syntax};

fuzz_target!(|data: &[u8]| {
    let text = match syntax::source_text(data) {
        Ok(t) => t,
        Err(d) => {
            let lossy = String::from_utf8_lossy(data);
            let _ = diag::render(&[d], "fuzz.surf", &lossy, false);
            return;
        }
    };
    let (file, mut diags) = syntax::parse(text);
    let Some(file) = file else {
        let _ = diag::render(&diags, "fuzz.surf", text, false);
        return;
    };
    let (_, more) = sema::check(&file);
    diags.extend(more);
    let _ = diag::render(&diags, "fuzz.surf", text, false);

    let formatted = syntax::format(&file);
    let (again, again_diags) = syntax::parse(&formatted);
    let Some(again) = again else {
        panic!("the formatted text does not parse: {again_diags:?}\n--- formatted\n{formatted}");
    };
    assert_eq!(
        syntax::sexpr(&file),
        syntax::sexpr(&again),
        "fmt changed the AST\n--- formatted\n{formatted}"
    );
    let comments = |f: &syntax::ast::File| -> Vec<String> {
        f.comments.iter().map(|c| c.text.clone()).collect()
    };
    assert_eq!(
        comments(&file),
        comments(&again),
        "fmt changed the comments"
    );
    assert_eq!(formatted, syntax::format(&again), "fmt is not idempotent");
});
