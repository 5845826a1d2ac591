//! Every message a user reads, worded in one place: one constructor per diagnostic, with its
//! code. `CODES` lists every code with a one-line meaning (docs/language.md has the index
//! with examples). Names in messages are quoted with backticks.

use crate::span::Span;

use super::Diagnostic;

/// Every diagnostic code and what it means.
pub const CODES: &[(&str, &str)] = &[
    ("E0001", "characters that start no token"),
    ("E0002", "unterminated block comment"),
    ("E0003", "unclosed parenthesis or brace"),
    ("E0004", "unmatched closing parenthesis or brace"),
    ("E0005", "nesting deeper than the limit"),
    ("E0006", "missing `;`"),
    ("E0007", "unexpected token"),
    ("E0008", "expected a definition"),
    ("E0009", "the file is not UTF-8 text"),
    ("E0010", "too many errors; the rest are not shown"),
    ("E0011", "unterminated string"),
    ("E0099", "internal error of the parser (a bug in surfc)"),
    ("E0101", "unknown name"),
    ("E0102", "duplicate definition"),
    ("E0103", "a built-in name redefined"),
    ("E0104", "recursive definition"),
    ("E0105", "duplicate parameter"),
    ("E0106", "an imported file that cannot be read"),
    ("E0107", "an import cycle"),
    ("E0108", "imports nested deeper than the limit"),
    ("E0201", "a patch used as a value"),
    ("E0202", "a name of the wrong kind"),
    (
        "E0203",
        "a function using x, y, z called where there are no coordinates",
    ),
    ("E0204", "x, y or z where there are no coordinates"),
    ("E0205", "a surface's value where there are no coordinates"),
    ("E0206", "a function used without calling it"),
    ("E0207", "a call of something that is not a function"),
    ("E0208", "a curve where a value is expected"),
    ("E0209", "a tuple where a number is expected"),
    (
        "E0210",
        "the intersection curve and the intersection boolean mixed up",
    ),
    ("E0211", "a transform of an expression that uses `dist`"),
    ("E0301", "wrong number of arguments"),
    ("E0302", "missing named argument"),
    ("E0303", "unknown or misplaced named argument"),
    ("E0304", "duplicate named argument"),
    ("E0401", "a constant value that is infinite or not a number"),
    ("E0402", "a number literal too large for f64"),
    ("E0403", "a point with the wrong number of components"),
    ("E0404", "a patch body that is not a 3-tuple"),
    ("E0405", "an empty or inverted patch range"),
    ("E0406", "a patch without exactly two parameters"),
    (
        "E0407",
        "a circle with a non-positive radius or a zero normal",
    ),
    (
        "E0408",
        "a primitive, smooth boolean, rotation or scale with an invalid size",
    ),
    ("E0501", "unknown mesh option"),
    ("E0502", "duplicate mesh option"),
    ("E0503", "missing `step`"),
    ("E0504", "non-positive `step`"),
    ("E0505", "`max_triangles` that is not a positive integer"),
    ("E0506", "a mesh with neither `start`, `front` nor `box`"),
    ("E0507", "an empty, inverted or too thin `box`"),
    ("E0508", "a mesh option with a value of the wrong shape"),
    ("E0509", "meshes sharing a curve with different steps"),
    ("E0510", "a patch meshed directly"),
    ("E0521", "a `tolerance` that is not a positive number"),
    ("E0522", "a `uniform` that is not `true` or `false`"),
    ("E0523", "a `radius_ratio` that is not a number in (0, 1]"),
    ("E0601", "a mesh that could not be completed"),
    (
        "E0602",
        "a surface or curve of a mesh that could not be built",
    ),
    ("E0603", "a surface too large after inlining its functions"),
    ("E0604", "`dist` nested deeper than the limit"),
    ("E0605", "a mesh block whose box holds no surface"),
    (
        "E0701",
        "`-D NAME=VALUE` for a name that is no constant of the file",
    ),
    ("W0001", "unused definition"),
    ("W0002", "`start` ignored because `front` is given"),
];

/// A number as a message shows it: Rust's shortest round-trip form, in scientific notation
/// when it is very large or very small, so that `1e300` is not echoed as 301 digits.
pub fn number(v: f64) -> String {
    let a = v.abs();
    if a.is_finite() && a != 0.0 && !(1e-4..1e15).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

fn or_list(items: &[&str]) -> String {
    match items {
        [] => String::new(),
        [one] => one.to_string(),
        [init @ .., last] => format!("{} or {}", init.join(", "), last),
    }
}

fn found_words(text: &str) -> String {
    if text.is_empty() {
        "the end of the file".to_string()
    } else {
        format!("`{text}`")
    }
}

// ---- syntax -------------------------------------------------------------------------------

pub fn stray_characters(span: Span, text: &str) -> Diagnostic {
    let what = if text.chars().count() == 1 {
        format!("unexpected character `{text}`")
    } else {
        format!("unexpected characters `{text}`")
    };
    let mut d = Diagnostic::error("E0001", what).primary(span, "no token starts with this");
    if text.contains('#') || text.contains('%') {
        d = d.help("comments start with `//` or are enclosed in `/* */`");
    } else {
        d = d.note("a .surf file uses letters, digits, `_`, and `+ - * / ^ ( ) , : ; = { } .`");
    }
    d
}

pub fn unterminated_comment(span: Span) -> Diagnostic {
    Diagnostic::error("E0002", "unterminated block comment")
        .primary(span, "this comment is never closed")
        .help("close it with `*/`")
}

pub fn unclosed_paren(opens: &[Span]) -> Diagnostic {
    let mut d = Diagnostic::error("E0003", "unclosed `(`");
    // The outermost few are enough to find the place.
    for &s in opens.iter().take(3) {
        d = d.primary(s, "this `(` is never closed");
    }
    if opens.len() > 3 {
        d = d.note(format!(
            "{} more `(` are not closed either",
            opens.len() - 3
        ));
    }
    d.help("add the missing `)` before the end of the statement")
}

pub fn unclosed_brace(span: Span) -> Diagnostic {
    Diagnostic::error("E0003", "unclosed `{`")
        .primary(span, "this `{` is never closed")
        .help("end the mesh block with `}`")
}

pub fn unmatched_close(span: Span, c: char) -> Diagnostic {
    Diagnostic::error("E0004", format!("unmatched `{c}`"))
        .primary(span, format!("this `{c}` closes nothing"))
}

/// Nesting deeper than the syntax's limits (`syntax::limits`, passed in: the limits are the
/// parser's).
pub fn nesting_too_deep(span: Span, max_parens: usize, max_depth: usize) -> Diagnostic {
    Diagnostic::error("E0005", "expression nested too deeply")
        .primary(span, "nesting goes deeper than surfc allows here")
        .note(format!(
            "at most {max_parens} nested parentheses and an expression depth of {max_depth} are allowed"
        ))
        .help("split the expression with `fn` or `const` definitions")
}

/// What a statement is called in a syntax error.
pub fn statement_context(keyword: &str, in_block: bool) -> &'static str {
    match keyword {
        "const" => "the constant definition",
        "fn" => "the function definition",
        "surface" => "the surface definition",
        "patch" => "the patch definition",
        "curve" => "the curve definition",
        "mesh" if in_block => "the mesh option",
        _ => "the mesh definition",
    }
}

pub fn expected_semicolon(at: Span, found: Span, found_text: &str, context: &str) -> Diagnostic {
    let mut d = Diagnostic::error("E0006", format!("expected `;` after {context}"))
        .primary(at, "add `;` here");
    if !found_text.is_empty() {
        d = d.secondary(found, format!("found {} instead", found_words(found_text)));
    }
    d
}

pub fn expected_tokens(
    found: Span,
    found_text: &str,
    expected: &[&str],
    context: &str,
    found_keyword: bool,
) -> Diagnostic {
    let list = or_list(expected);
    let mut d = Diagnostic::error(
        "E0007",
        format!(
            "expected {list} in {context}, found {}",
            found_words(found_text)
        ),
    )
    .primary(found, format!("expected {list}"));
    if found_keyword {
        d = d.note(format!(
            "`{found_text}` is a keyword and cannot be used as a name"
        ));
    }
    d
}

pub fn expected_statement(found: Span, found_text: &str, keywords: &[&str]) -> Diagnostic {
    let list: Vec<String> = keywords.iter().map(|k| format!("`{k}`")).collect();
    let list: Vec<&str> = list.iter().map(String::as_str).collect();
    let d = Diagnostic::error(
        "E0008",
        format!("expected a definition, found {}", found_words(found_text)),
    )
    .primary(found, "a statement starts with a keyword")
    .note(format!("the keywords are {}", or_list(&list)));
    match super::suggest::nearest(found_text, keywords.iter().copied()) {
        Some(k) => d.help(format!("did you mean `{k}`?")),
        None => d,
    }
}

/// `offset` is the first invalid byte; the label covers the replacement character that a
/// lossy decoding puts there (render the diagnostic with that decoding).
pub fn not_utf8(offset: usize, line: usize) -> Diagnostic {
    Diagnostic::error("E0009", "the file is not UTF-8 text")
        .primary(
            Span::new(offset, offset + char::REPLACEMENT_CHARACTER.len_utf8()),
            "not a UTF-8 character",
        )
        .note(format!(
            "the first invalid byte is on line {line}, at byte offset {offset}"
        ))
        .help("save the file as UTF-8")
}

pub fn suppressed(count: usize) -> Diagnostic {
    Diagnostic::error("E0010", format!("{count} more errors not shown"))
        .note("fix the errors above first")
}

pub fn internal_parse(span: Span) -> Diagnostic {
    Diagnostic::error(
        "E0099",
        "internal error: the parse tree has an unexpected shape",
    )
    .primary(span, "while reading this")
    .note("this is a bug in surfc; please report it with this file")
}

// ---- names --------------------------------------------------------------------------------

pub fn unknown_name(span: Span, name: &str, suggestion: Option<&str>) -> Diagnostic {
    let d =
        Diagnostic::error("E0101", format!("unknown name `{name}`")).primary(span, "not defined");
    match suggestion {
        Some(s) => d.help(format!("did you mean `{s}`?")),
        None => d,
    }
}

pub fn unknown_function(span: Span, name: &str, suggestion: Option<&str>) -> Diagnostic {
    let d = Diagnostic::error("E0101", format!("unknown function `{name}`"))
        .primary(span, "no function of this name");
    match suggestion {
        Some(s) => d.help(format!("did you mean `{s}`?")),
        None => d,
    }
}

pub fn duplicate_definition(what: &str, name: &str, first: Span, second: Span) -> Diagnostic {
    Diagnostic::error("E0102", format!("`{name}` is defined twice"))
        .primary(second, format!("second definition of {what} `{name}`"))
        .secondary(first, "first defined here")
        .help("rename one of them")
}

pub fn reserved_name(span: Span, name: &str, what: &str) -> Diagnostic {
    Diagnostic::error(
        "E0103",
        format!("`{name}` is {what} and cannot be redefined"),
    )
    .primary(span, "this name is taken by the language")
    .help("choose another name")
}

/// `cycle`: (name, span of the name's definition, span where it uses the next). Long cycles
/// show their first `MAX_CYCLE_STEPS` steps.
pub fn recursive_definition(cycle: &[(String, Span, Span)]) -> Diagnostic {
    const MAX_CYCLE_STEPS: usize = 8;
    let shown = &cycle[..cycle.len().min(MAX_CYCLE_STEPS)];
    let mut names: Vec<String> = shown.iter().map(|(n, _, _)| format!("`{n}`")).collect();
    if cycle.len() > shown.len() {
        names.push(format!("… ({} more)", cycle.len() - shown.len()));
    }
    let mut chain = names.join(" → ");
    let (first_name, first_def, _) = &cycle[0];
    chain.push_str(&format!(" → `{first_name}`"));
    let mut d = Diagnostic::error(
        "E0104",
        format!("recursive definition: `{first_name}` depends on itself"),
    )
    .primary(*first_def, "defined in terms of itself");
    for (i, (name, _, use_span)) in shown.iter().enumerate() {
        let next = &cycle[(i + 1) % cycle.len()].0;
        d = d.secondary(*use_span, format!("`{name}` uses `{next}` here"));
    }
    d.note(format!("the cycle is {chain}"))
        .help("definitions are expanded in place, so none may refer back to itself")
}

pub fn duplicate_parameter(name: &str, first: Span, second: Span) -> Diagnostic {
    Diagnostic::error("E0105", format!("parameter `{name}` is declared twice"))
        .primary(second, "second declaration")
        .secondary(first, "first declared here")
}

// ---- kinds --------------------------------------------------------------------------------

pub fn patch_as_value(span: Span, name: &str) -> Diagnostic {
    Diagnostic::error("E0201", format!("patch `{name}` has no value"))
        .primary(span, "a patch cannot be used as a number")
        .help(format!(
            "use its oriented distance `dist({name})`, or `offset({name}, d)`"
        ))
}

/// A name of kind `found` where `expected` is needed, e.g. a surface where a curve is expected.
pub fn wrong_kind(
    span: Span,
    name: &str,
    found: &str,
    expected: &str,
    help: Option<String>,
) -> Diagnostic {
    Diagnostic::error(
        "E0202",
        format!("expected {expected}, but `{name}` is {found}"),
    )
    .primary(span, format!("this is {found}"))
    .maybe_help(help)
}

/// What was found where a curve is expected, for the help of `expected_curve`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FoundInsteadOfCurve {
    Surface,
    Patch,
    Other,
}

const CURVE_FORMS: &str =
    "a curve is `intersection(…)`, `circle(…)`, `boundary(P)` or `reverse(C)`";

/// A name of another kind (`found` is "a surface", …) or an expression (`name` None) where a
/// curve is expected.
pub fn expected_curve(
    span: Span,
    name: Option<&str>,
    found: &str,
    what: FoundInsteadOfCurve,
) -> Diagnostic {
    let Some(name) = name else {
        return wrong_kind(
            span,
            "this expression",
            "not a curve",
            "a curve",
            Some(CURVE_FORMS.into()),
        );
    };
    let help = match what {
        FoundInsteadOfCurve::Surface => {
            format!("a curve on `{name}` is, e.g., `intersection({name}, z - 1, near: (1, 0, 1))`")
        }
        FoundInsteadOfCurve::Patch => format!("the boundary of a patch is `boundary({name})`"),
        FoundInsteadOfCurve::Other => CURVE_FORMS.to_string(),
    };
    wrong_kind(span, name, found, "a curve", Some(help))
}

/// `boundary(…)` of something that is not a patch (`name` None: an expression).
pub fn expected_patch(span: Span, name: Option<(&str, &str)>) -> Diagnostic {
    let help = Some("`boundary` takes the name of a patch".to_string());
    match name {
        Some((name, found)) => wrong_kind(span, name, found, "a patch", help),
        None => wrong_kind(span, "this expression", "not a patch", "a patch", help),
    }
}

/// A curve's name where a surface is expected.
pub fn curve_as_surface(span: Span, name: &str) -> Diagnostic {
    wrong_kind(
        span,
        name,
        "a curve",
        "a surface",
        Some("a surface is a formula of x, y, z, a surface's or a patch's name".into()),
    )
}

pub fn coordinate_fn_without_coordinates(
    span: Span,
    name: &str,
    place: &str,
    def: Span,
) -> Diagnostic {
    Diagnostic::error(
        "E0203",
        format!("`{name}` uses x, y or z and cannot be called in {place}"),
    )
    .primary(span, format!("there are no coordinates in {place}"))
    .secondary(def, format!("`{name}` is defined here"))
    .help("call it from a surface, or pass the coordinates as parameters")
}

pub fn coordinate_without_coordinates(span: Span, axis: &str, place: &str) -> Diagnostic {
    let d = Diagnostic::error("E0204", format!("`{axis}` cannot be used in {place}"))
        .primary(span, format!("there are no coordinates in {place}"));
    if place.starts_with("a patch") {
        d.help("a patch is a function of its parameters; write it in terms of them")
    } else {
        d.help("a constant is computed once, before any point exists; use it in a surface instead")
    }
}

pub fn surface_without_coordinates(span: Span, name: &str, place: &str) -> Diagnostic {
    Diagnostic::error("E0205", format!("surface `{name}` has no value in {place}")).primary(
        span,
        format!("a surface's value needs x, y, z, which {place} lacks"),
    )
}

pub fn fn_without_call(span: Span, name: &str, signature: &str) -> Diagnostic {
    Diagnostic::error("E0206", format!("function `{name}` is used without a call"))
        .primary(span, "a function is not a value")
        .help(format!("call it: `{signature}`"))
}

pub fn not_callable(span: Span, name: &str, kind: &str) -> Diagnostic {
    Diagnostic::error("E0207", format!("`{name}` is {kind}, not a function"))
        .primary(span, "cannot be called")
}

pub fn curve_as_value(span: Span, what: &str) -> Diagnostic {
    Diagnostic::error("E0208", format!("{what} is a curve, not a value"))
        .primary(span, "a curve cannot be used in an expression")
        .help("curves belong in `curve` definitions and in a mesh's `front:` and `bounds:`")
}

pub fn tuple_as_number(span: Span) -> Diagnostic {
    Diagnostic::error("E0209", "a tuple where a number is expected")
        .primary(span, "this is a tuple")
        .note("tuples are points: `start:`, `box:`, `near:`, `center:`, `normal:` and patch bodies")
}

// ---- calls --------------------------------------------------------------------------------

pub fn wrong_arity(
    span: Span,
    name: &str,
    signature: &str,
    expected: &str,
    got: usize,
) -> Diagnostic {
    Diagnostic::error(
        "E0301",
        format!(
            "`{name}` takes {expected}, but {got} {} given",
            if got == 1 { "is" } else { "are" }
        ),
    )
    .primary(
        span,
        format!("{got} argument{} given", if got == 1 { "" } else { "s" }),
    )
    .help(format!("the signature is `{signature}`"))
}

pub fn missing_named_argument(span: Span, callee: &str, arg: &str, signature: &str) -> Diagnostic {
    Diagnostic::error(
        "E0302",
        format!("`{callee}` needs the named argument `{arg}`"),
    )
    .primary(span, format!("`{arg}:` is missing"))
    .help(format!("the signature is `{signature}`"))
}

pub fn unexpected_named_argument(
    span: Span,
    callee: &str,
    arg: &str,
    signature: &str,
) -> Diagnostic {
    Diagnostic::error("E0303", format!("`{callee}` has no argument named `{arg}`"))
        .primary(span, "not expected here")
        .help(format!("the signature is `{signature}`"))
}

/// An argument without a name past the `positional` ones a call takes.
pub fn positional_where_named(
    span: Span,
    callee: &str,
    positional: usize,
    signature: &str,
) -> Diagnostic {
    let message = match positional {
        0 => format!("`{callee}` takes named arguments only"),
        1 => format!("`{callee}` takes 1 argument without a name, then named ones"),
        n => format!("`{callee}` takes {n} arguments without a name, then named ones"),
    };
    Diagnostic::error("E0303", message)
        .primary(span, "this argument has no name")
        .help(format!("the signature is `{signature}`"))
}

pub fn duplicate_named_argument(arg: &str, first: Span, second: Span) -> Diagnostic {
    Diagnostic::error("E0304", format!("argument `{arg}` is given twice"))
        .primary(second, "given again here")
        .secondary(first, "first given here")
}

// ---- values -------------------------------------------------------------------------------

pub fn not_finite(span: Span, what: &str, value: f64) -> Diagnostic {
    let v = if value.is_nan() {
        "not a number (NaN)".to_string()
    } else {
        format!("{}infinite", if value < 0.0 { "negative " } else { "" })
    };
    Diagnostic::error("E0401", format!("{what} is {v}"))
        .primary(span, format!("evaluates to {}", number(value)))
        .help("check for a division by zero, a logarithm of zero or a number too large")
}

pub fn literal_too_large(span: Span) -> Diagnostic {
    Diagnostic::error("E0402", "number literal too large")
        .primary(span, "exceeds the largest f64 (about 1.8e308)")
}

pub fn wrong_point_arity(span: Span, got: usize) -> Diagnostic {
    Diagnostic::error("E0403", format!("a point has 3 components, this has {got}"))
        .primary(
            span,
            format!("{got} component{}", if got == 1 { "" } else { "s" }),
        )
        .help("write a point as `(x, y, z)`")
}

pub fn patch_body_not_triple(span: Span, got: Option<usize>) -> Diagnostic {
    let label = match got {
        Some(n) => format!("a tuple of {n} components"),
        None => "not a tuple".to_string(),
    };
    Diagnostic::error("E0404", "a patch body must be a point `(X, Y, Z)`")
        .primary(span, label)
        .help("write the patch as `patch P(u: 0..1, v: 0..1) = (X, Y, Z);`")
}

pub fn inverted_range(span: Span, param: &str, lo: f64, hi: f64) -> Diagnostic {
    let what = if lo == hi { "empty" } else { "inverted" };
    Diagnostic::error(
        "E0405",
        format!(
            "the range of `{param}` is {what}: {}..{}",
            number(lo),
            number(hi)
        ),
    )
    .primary(span, "the lower bound must be less than the upper")
    .maybe_help((lo > hi).then(|| format!("swap the bounds: `{}..{}`", number(hi), number(lo))))
}

pub fn patch_param_count(span: Span, got: usize) -> Diagnostic {
    Diagnostic::error(
        "E0406",
        format!("a patch has exactly two parameters, this has {got}"),
    )
    .primary(span, "parameters declared here")
    .help("write `patch P(u: 0..1, v: 0..1) = (X, Y, Z);`")
}

pub fn bad_circle(span: Span, what: &str) -> Diagnostic {
    Diagnostic::error("E0407", format!("invalid circle: {what}")).primary(span, what.to_string())
}

// ---- meshes -------------------------------------------------------------------------------

pub fn unknown_mesh_option(span: Span, name: &str, suggestion: Option<&str>) -> Diagnostic {
    let d = Diagnostic::error("E0501", format!("unknown mesh option `{name}`"))
        .primary(span, "not a mesh option")
        .note("the options are `step`, `start`, `box`, `front`, `bounds`, `max_triangles`, `tolerance` and `uniform`");
    match suggestion {
        Some(s) => d.help(format!("did you mean `{s}`?")),
        None => d,
    }
}

pub fn duplicate_mesh_option(name: &str, first: Span, second: Span) -> Diagnostic {
    Diagnostic::error("E0502", format!("mesh option `{name}` is given twice"))
        .primary(second, "given again here")
        .secondary(first, "first given here")
        .help("remove one of them")
}

pub fn missing_step(span: Span, mesh: &str) -> Diagnostic {
    Diagnostic::error("E0503", format!("mesh `{mesh}` has no `step`"))
        .primary(span, "`step:` is required")
        .help("add the triangles' edge length, e.g. `step: 0.1;` (about 1/30 of the model's size)")
}

pub fn non_positive_step(span: Span, value: f64) -> Diagnostic {
    Diagnostic::error(
        "E0504",
        format!("`step` must be positive, it is {}", number(value)),
    )
    .primary(span, "the step is the edge length of the triangles")
}

pub fn bad_max_triangles(span: Span, value: f64) -> Diagnostic {
    let label = if value >= 1.0 && value.fract() == 0.0 {
        "more than a 64-bit count can hold"
    } else {
        "not a positive whole number"
    };
    Diagnostic::error(
        "E0505",
        format!(
            "`max_triangles` must be a positive whole number below 2^64, it is {}",
            number(value)
        ),
    )
    .primary(span, label)
    .note("the default is sized from the mesh's box and step; see docs/language.md")
}

pub fn no_start(span: Span, mesh: &str) -> Diagnostic {
    Diagnostic::error(
        "E0506",
        format!("mesh `{mesh}` has neither `start`, `front` nor `box`"),
    )
    .primary(span, "the marcher needs to know what to mesh")
    .help("add `start: (x, y, z);` near the surface (the component through it), `front: CURVE;` (the area the curve starts), or `box: (x0, y0, z0) .. (x1, y1, z1);` (every component in the box)")
}

pub fn bad_box(span: Span, axis: &str, lo: f64, hi: f64) -> Diagnostic {
    let what = if lo == hi { "empty" } else { "inverted" };
    Diagnostic::error(
        "E0507",
        format!(
            "the box is {what} along {axis}: {} .. {}",
            number(lo),
            number(hi)
        ),
    )
    .primary(
        span,
        "each component of the first corner must be less than the second's",
    )
    .help("write `box: (xmin, ymin, zmin) .. (xmax, ymax, zmax);`")
}

/// A box narrower along `axis` than `min` (a fixed fraction of the step): no triangle fits.
pub fn thin_box(span: Span, axis: &str, width: f64, min: f64) -> Diagnostic {
    Diagnostic::error(
        "E0507",
        format!(
            "the box is only {} wide along {axis}, less than {} (a millionth of the step)",
            number(width),
            number(min)
        ),
    )
    .primary(span, "too thin to hold a triangle")
    .help("widen the box, or leave it out")
}

pub fn option_shape(span: Span, option: &str, expected: &str) -> Diagnostic {
    Diagnostic::error(
        "E0508",
        format!("mesh option `{option}` expects {expected}"),
    )
    .primary(span, format!("expected {expected}"))
}

pub fn shared_curve_steps(
    curve: &str,
    first: (&str, f64, Span),
    second: (&str, f64, Span),
) -> Diagnostic {
    Diagnostic::error(
        "E0509",
        format!(
            "meshes `{}` and `{}` share curve `{curve}` with different steps",
            first.0, second.0
        ),
    )
    .primary(
        second.2,
        format!("`{}` samples it at step {}", second.0, number(second.1)),
    )
    .secondary(
        first.2,
        format!("`{}` samples it at step {}", first.0, number(first.1)),
    )
    .note("meshes that share a curve share its polygon, which is sampled at the mesh's step")
    .help("give both meshes the same `step`")
}

pub fn patch_meshed(span: Span, name: &str) -> Diagnostic {
    Diagnostic::error("E0510", format!("patch `{name}` cannot be meshed directly"))
        .primary(span, "the marcher meshes implicit surfaces")
        .help(format!("mesh its implicitization: `dist({name})`"))
}

pub fn bad_tolerance(span: Span, value: f64) -> Diagnostic {
    Diagnostic::error(
        "E0521",
        format!("`tolerance` must be a positive number, it is {value}"),
    )
    .primary(
        span,
        "the largest distance between the mesh and the surface",
    )
    .help("leave it out for the default, a tenth of the step")
}

pub fn bad_uniform(span: Span) -> Diagnostic {
    Diagnostic::error("E0522", "`uniform` must be `true` or `false`")
        .primary(span, "not `true` or `false`")
        .help("`uniform: true;` meshes with the step everywhere, as the paper does")
}

pub fn bad_radius_ratio(span: Span, value: f64) -> Diagnostic {
    Diagnostic::error(
        "E0523",
        format!("`radius_ratio` must be a number above 0 and at most 1, it is {value}"),
    )
    .primary(
        span,
        "the mean radius ratio the quality stage raises the mesh to",
    )
    .help("leave it out for the default, 0.975; 1 asks for every phase of the quality stage")
}

// ---- warnings -----------------------------------------------------------------------------

pub fn unused(span: Span, what: &str, name: &str) -> Diagnostic {
    Diagnostic::warning("W0001", format!("{what} `{name}` is never used"))
        .primary(span, "defined here")
        .help("remove it, or prefix its name with `_` to keep it")
}

pub fn start_ignored(start: Span, front: Span) -> Diagnostic {
    Diagnostic::warning("W0002", "`start` is ignored when `front` is given")
        .primary(start, "ignored")
        .secondary(front, "the front polygon is where meshing begins")
}

/// A mesh block whose triangulation could not be completed (the marcher's reason, with the
/// coordinates where it happened), with a help fitting the reason.
pub fn mesh_failed(name: &str, span: Span, reason: &str, help: Option<&str>) -> Diagnostic {
    Diagnostic::error("E0601", format!("mesh `{name}` could not be completed"))
        .primary(span, "this mesh block")
        .note(reason.to_string())
        .maybe_help(help.map(str::to_string))
}

/// The range of f seen over a mesh block's box: an interval bound, and the smallest and
/// largest values sampled on a grid (with the number of samples, and of those where f is
/// not a number).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub bound: Option<(f64, f64)>,
    pub sampled: Option<(f64, f64)>,
    pub samples: usize,
    pub undefined: usize,
}

/// A mesh block with a `box` (and no start or front) in which no surface was found: nothing
/// to mesh is an error, not an empty file. Says what f does over the box; `found` are the
/// search's warnings (components smaller than the step that were not meshed).
pub fn empty_box(
    name: &str,
    span: Span,
    (lo, hi): ([f64; 3], [f64; 3]),
    range: Range,
    found: &[String],
) -> Diagnostic {
    let point = |p: [f64; 3]| format!("({}, {}, {})", number(p[0]), number(p[1]), number(p[2]));
    // Six significant digits: an outward-rounded bound printed in full is noise.
    let short = |v: f64| number(format!("{v:.5e}").parse().unwrap_or(v));
    let interval = |(a, b): (f64, f64)| format!("[{}, {}]", short(a), short(b));
    let mut seen = Vec::new();
    if let Some(b) = range.bound {
        seen.push(format!("within {} by interval arithmetic", interval(b)));
    }
    if let Some(s) = range.sampled {
        seen.push(format!(
            "over {} at {} points sampled on a grid",
            interval(s),
            range.samples
        ));
    }
    if range.undefined > 0 {
        seen.push(format!("not a number at {} of them", range.undefined));
    }
    let seen = if seen.is_empty() {
        "f could not be evaluated there".to_string()
    } else {
        format!("f ranges {}", seen.join(", and "))
    };
    let what = match (found.is_empty(), range.sampled) {
        (true, Some(s)) => format!(
            "no surface was found in its box, where f ranges over {}",
            interval(s)
        ),
        (true, None) => "no surface was found in its box".to_string(),
        (false, _) => "nothing in its box could be meshed".to_string(),
    };
    let mut d = Diagnostic::error("E0605", format!("mesh `{name}`: {what}"))
        .primary(span, "this mesh block")
        .note(format!("the box {} .. {}: {seen}", point(lo), point(hi)));
    for f in found {
        d = d.note(f.clone());
    }
    d.help("the surface is where f changes sign: move or widen the `box` to where it does, or check the formula (a constant's sign, a missing term)")
}

/// A mesh block whose surface or curves could not be built (a curve that cannot be traced,
/// a surface that cannot be compiled); `curve` is the definition of the curve at fault.
pub fn mesh_build_failed(
    name: &str,
    span: Span,
    reason: &dyn std::fmt::Display,
    curve: Option<Span>,
) -> Diagnostic {
    let d = Diagnostic::error("E0602", format!("mesh `{name}`: {reason}"))
        .primary(span, "in this mesh block");
    match curve {
        Some(c) => d.secondary(c, "the curve is defined here"),
        None => d,
    }
}

/// A surface whose inlined functions pass the size limit; `span` is the outermost call of
/// the chain of functions being inlined.
pub fn surface_too_large(span: Span, nodes: usize, limit: usize, chain: &[String]) -> Diagnostic {
    let label = match chain {
        [] => "this expression".to_string(),
        [only] => format!("inlining `{only}` here"),
        _ => format!(
            "inlining {} here",
            chain
                .iter()
                .map(|f| format!("`{f}`"))
                .collect::<Vec<_>>()
                .join(" → ")
        ),
    };
    Diagnostic::error(
        "E0603",
        format!("the surface is too large: more than {limit} operations after inlining"),
    )
    .primary(span, label)
    .note(format!(
        "lowering stopped at {nodes} operations; each call inlines its function's body, so functions that call another twice double in size at every level"
    ))
    .help("compute a repeated value once (a `const`, or one call whose result is used twice), or write the function with fewer nested calls")
}

/// `dist` nested deeper than the limit; `span` is the innermost `dist` call of the chain.
pub fn dist_too_deep(span: Span, limit: usize, chain: &[String]) -> Diagnostic {
    Diagnostic::error(
        "E0604",
        format!("`dist` is nested more than {limit} deep"),
    )
    .primary(span, format!("level {} of {}", chain.len(), chain.join(" → ")))
    .note("each level of `dist` evaluates the one inside it tens of times per foot point, so the work grows about 30-fold a level")
    .help("measure the distance to the innermost surface once: `offset(S, a + b)` instead of `offset(offset(S, a), b)`")
}

/// `intersection(…, near: P)` in a surface, where `intersection` is the boolean.
pub fn near_in_boolean(span: Span) -> Diagnostic {
    Diagnostic::error(
        "E0210",
        "`near:` belongs to the intersection curve, not to the intersection boolean",
    )
    .primary(span, "in a surface, `intersection(…)` is the boolean (max)")
    .help("to trace the curve where the surfaces meet, declare it: `curve NAME = intersection(S1, S2, near: P);`")
}

/// A boolean, primitive or transform (a surface) where a curve is declared.
pub fn solid_in_curve(span: Span, name: &str) -> Diagnostic {
    Diagnostic::error("E0210", format!("`{name}(…)` is a surface, not a curve"))
        .primary(span, "a solid where a curve is expected")
        .help(format!(
            "declare it as a surface, `surface NAME = {name}(…);`; a curve on two surfaces is `intersection(S1, S2, near: P)`"
        ))
}

/// `translate`, `rotate` or `scale` of an expression with a `dist` in it.
pub fn dist_in_transform(span: Span, transform: &str) -> Diagnostic {
    Diagnostic::error(
        "E0211",
        format!("`{transform}` of an expression that uses `dist` is not supported"),
    )
    .primary(
        span,
        "`dist` measures at the point the mesher asks for, not at a transformed one",
    )
    .help(format!(
        "transform the surface inside instead: `dist({transform}(S, …))`"
    ))
}

/// A primitive's size, a rounding radius, a rotation axis or a scale factor that is invalid.
pub fn bad_solid_parameter(span: Span, callee: &str, what: &str, signature: &str) -> Diagnostic {
    Diagnostic::error("E0408", format!("invalid `{callee}`: {what}"))
        .primary(span, what.to_string())
        .help(format!("the signature is `{signature}`"))
}

/// `-D NAME=…` where the file has no constant NAME (`kind`: what NAME is, if anything).
pub fn unknown_define(name: &str, kind: Option<&str>, constants: &[&str]) -> Diagnostic {
    let message = match kind {
        Some(kind) => format!("`-D {name}=…`: `{name}` is {kind}, not a constant"),
        None => format!("`-D {name}=…`: the file has no constant `{name}`"),
    };
    let help = if constants.is_empty() {
        "the file declares no constants; `-D` sets a `const`".to_string()
    } else {
        let list: Vec<String> = constants.iter().map(|c| format!("`{c}`")).collect();
        format!("the file's constants are {}", list.join(", "))
    };
    Diagnostic::error("E0701", message).help(help)
}

pub fn unterminated_string(span: Span) -> Diagnostic {
    Diagnostic::error("E0011", "unterminated string")
        .primary(span, "this string has no closing `\"` on its line")
        .help("write a file name in quotes on one line: `import \"parts.surf\";`")
}

/// An `import` whose file cannot be read.
pub fn import_unreadable(span: Span, written: &str, resolved: &str, why: &str) -> Diagnostic {
    Diagnostic::error("E0106", format!("cannot import `{written}`: {why}"))
        .primary(span, "this file cannot be read")
        .note(format!("looked for `{resolved}`"))
        .help("an import's path is relative to the file that imports it")
}

/// An `import` that closes a cycle; `other` is the import that started it.
pub fn import_cycle(span: Span, written: &str, other: Option<Span>) -> Diagnostic {
    let d = Diagnostic::error(
        "E0107",
        format!("import cycle: `{written}` is already being imported"),
    )
    .primary(span, format!("imports `{written}` again"));
    match other {
        Some(other) => d
            .secondary(other, "the cycle starts with this import")
            .help("move what both files need into a third file that both import"),
        None => d.help("a file cannot import itself"),
    }
}

/// Imports nested deeper than the limit.
pub fn imports_too_deep(span: Span, limit: usize) -> Diagnostic {
    Diagnostic::error("E0108", format!("imports nested deeper than {limit} files"))
        .primary(span, "one import too many")
}
