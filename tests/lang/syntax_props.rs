//! No input makes the front end panic: random text and mutations of the examples (deleted,
//! inserted, duplicated and swapped tokens and characters) go through parse, check, format
//! and render. Whenever a mutant parses, formatting it round-trips to the same AST.

use proptest::prelude::*;

use surfc::{diag, sema, syntax};

const EXAMPLES: [&str; 11] = [
    include_str!("../../examples/sphere.surf"),
    include_str!("../../examples/cylinder.surf"),
    include_str!("../../examples/torus.surf"),
    include_str!("../../examples/six_peak.surf"),
    include_str!("../../examples/genus3.surf"),
    include_str!("../../examples/three_cylinders.surf"),
    include_str!("../../examples/intersecting_patches.surf"),
    include_str!("../../examples/sphere_six_holes.surf"),
    include_str!("../../examples/two_surfaces.surf"),
    include_str!("../../examples/blend_three_cylinders.surf"),
    include_str!("../../examples/g2_set.surf"),
];

const TOKENS: [&str; 36] = [
    "(", ")", ",", ";", ":", "=", "{", "}", "..", "+", "-", "*", "/", "^", "x", "y", "z", "pi",
    "0", "1e999", "1/0", "dist(", "offset(", "blend(", "product(", "circle(", "reverse(", "mesh",
    "surface", "patch", "curve", "const", "fn", "step:", "//", "/*",
];

/// Runs the whole front end; panics only if it does.
fn run(text: &str) {
    let (file, mut diags) = syntax::parse(text);
    if let Some(file) = &file {
        let (_, more) = sema::check(file);
        diags.extend(more);
        let formatted = syntax::format(file);
        let (again, d2) = syntax::parse(&formatted);
        let again =
            again.unwrap_or_else(|| panic!("fmt output does not parse: {d2:?}\n{formatted}"));
        assert_eq!(
            syntax::sexpr(file),
            syntax::sexpr(&again),
            "fmt changed the AST of\n{text}"
        );
        assert_eq!(
            syntax::format(&again),
            formatted,
            "fmt is not idempotent on\n{text}"
        );
    }
    let _ = diag::render(&diags, "fuzz.surf", text, false);
}

#[derive(Clone, Debug)]
enum Mutation {
    Delete(usize, usize),
    Insert(usize, usize),
    Swap(usize, usize),
    Duplicate(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 1usize..12).prop_map(|(a, n)| Mutation::Delete(a, n)),
        (any::<usize>(), any::<usize>()).prop_map(|(a, t)| Mutation::Insert(a, t)),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::Swap(a, b)),
        (any::<usize>(), 1usize..40).prop_map(|(a, n)| Mutation::Duplicate(a, n)),
    ]
}

fn apply(text: &str, mutations: &[Mutation]) -> String {
    let mut chars: Vec<char> = text.chars().collect();
    for m in mutations {
        let len = chars.len().max(1);
        match *m {
            Mutation::Delete(a, n) => {
                let a = a % len;
                let b = (a + n).min(chars.len());
                if a < b {
                    chars.drain(a..b);
                }
            }
            Mutation::Insert(a, t) => {
                let a = a % (chars.len() + 1);
                let tok = TOKENS[t % TOKENS.len()];
                for (k, c) in tok.chars().enumerate() {
                    chars.insert(a + k, c);
                }
            }
            Mutation::Swap(a, b) => {
                if !chars.is_empty() {
                    let (a, b) = (a % chars.len(), b % chars.len());
                    chars.swap(a, b);
                }
            }
            Mutation::Duplicate(a, n) => {
                let a = a % len;
                let b = (a + n).min(chars.len());
                if a < b {
                    let piece: Vec<char> = chars[a..b].to_vec();
                    for (k, c) in piece.into_iter().enumerate() {
                        chars.insert(b + k, c);
                    }
                }
            }
        }
    }
    chars.into_iter().collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn random_text_never_panics(text in "[a-z0-9 ().,;:={}+*/^\n-]{0,300}") {
        run(&text);
    }

    #[test]
    fn random_unicode_never_panics(text in "\\PC{0,200}") {
        run(&text);
    }

    #[test]
    fn mutated_examples_never_panic(
        which in 0usize..EXAMPLES.len(),
        mutations in proptest::collection::vec(mutation(), 1..6),
    ) {
        run(&apply(EXAMPLES[which], &mutations));
    }
}

#[test]
fn examples_pass_the_front_end() {
    for text in EXAMPLES {
        run(text);
        let (file, diags) = syntax::parse(text);
        assert!(diags.is_empty(), "{diags:?}");
        let (_, diags) = sema::check(&file.expect("parses"));
        assert!(!diag::has_errors(&diags), "{diags:?}");
    }
}

/// A hundred thousand levels of nesting are a diagnostic on a test thread's 2 MiB stack.
#[test]
fn deep_nesting_is_a_diagnostic() {
    let n = 100_000;
    let cases = [
        format!("surface s = {}x{};", "(".repeat(n), ")".repeat(n)),
        format!("surface s = {}x;", "-".repeat(n)),
        format!("surface s = x{};", "^x".repeat(n)),
        format!("surface s = x{};", " * 2".repeat(n)),
        format!("surface s = {}1{};", "f(".repeat(n), ")".repeat(n)),
        format!("surface s = {}x;", "- (".repeat(n)),
    ];
    for text in cases {
        let (file, diags) = syntax::parse(&text);
        assert!(file.is_none());
        assert!(
            diags.iter().any(|d| d.code == "E0005" || d.code == "E0003"),
            "{diags:?}"
        );
        run(&text);
    }
}
