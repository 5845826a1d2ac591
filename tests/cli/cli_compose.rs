//! The command line as a part of pipelines and scripts, through the binary: `-o -` writes
//! the mesh to stdout, FILE `-` reads stdin, `fmt --check` and `--write`, `--json` that
//! prints JSON on failure too, `--stats`, and `render` of an existing mesh file.

use crate::common::cli;

const SPHERE: &str = "surface sphere = x^2 + y^2 + z^2 - 4;\n\
                      mesh ball = sphere { step: 0.5; start: (1, 1, 1); }\n";

fn scratch() -> tempfile::TempDir {
    tempfile::tempdir().expect("a temporary directory")
}

#[test]
fn dash_o_dash_writes_the_same_bytes_as_a_file() {
    let dir = scratch();
    std::fs::write(dir.path().join("ball.surf"), SPHERE).expect("written");
    for format in ["obj", "stl", "ply", "off", "glb", "3mf", "msh", "vtu"] {
        let out = format!("ball.{format}");
        let (code, _, stderr) =
            cli::surfc(&["mesh", "ball.surf", "-o", &out, "-q"], dir.path()).bytes();
        assert_eq!(code, 0, "{stderr}");
        let (code, stdout, stderr) = cli::surfc(
            &["mesh", "ball.surf", "-o", "-", "--format", format],
            dir.path(),
        )
        .bytes();
        assert_eq!(code, 0, "{stderr}");
        let file = std::fs::read(dir.path().join(&out)).expect("the file");
        assert_eq!(stdout, file, "{format}");
        // The summary still goes to stderr, and says where the mesh went.
        assert!(stderr.contains("wrote standard output"), "{stderr}");
    }
    // No file named `-` appears.
    assert!(!dir.path().join("-").exists());
}

#[test]
fn dash_o_dash_needs_a_format_and_no_json() {
    let dir = scratch();
    std::fs::write(dir.path().join("ball.surf"), SPHERE).expect("written");
    let (code, stdout, stderr) = cli::surfc(&["mesh", "ball.surf", "-o", "-"], dir.path()).bytes();
    assert_eq!(code, 2);
    assert!(stdout.is_empty());
    assert!(stderr.contains("--format"), "{stderr}");
    let (code, stdout, stderr) = cli::surfc(
        &["mesh", "ball.surf", "-o", "-", "--format", "obj", "--json"],
        dir.path(),
    )
    .bytes();
    assert_eq!(code, 2);
    assert!(stderr.contains("--json"), "{stderr}");
    // --json still answers with JSON: the usage error.
    let json: serde_json::Value = serde_json::from_slice(&stdout).expect("JSON");
    assert_eq!(json["errors"][0]["code"], "usage");
    assert!(!dir.path().join("-").exists());
}

#[test]
fn dash_reads_standard_input() {
    let dir = scratch();
    let (code, stdout, stderr) = cli::surfc_with_input(
        &["mesh", "-", "-o", "-", "--format", "off", "-q"],
        dir.path(),
        SPHERE.as_bytes(),
    )
    .bytes();
    assert_eq!(code, 0, "{stderr}");
    std::fs::write(dir.path().join("ball.surf"), SPHERE).expect("written");
    let (_, from_file, _) = cli::surfc(
        &["mesh", "ball.surf", "-o", "-", "--format", "off", "-q"],
        dir.path(),
    )
    .bytes();
    assert_eq!(stdout, from_file);

    // Without -o there is no file name to name the output after.
    let (code, _, stderr) =
        cli::surfc_with_input(&["mesh", "-"], dir.path(), SPHERE.as_bytes()).bytes();
    assert_eq!(code, 2);
    assert!(stderr.contains("-o"), "{stderr}");

    // check, eval, bytecode and fmt read `-` too; diagnostics name it `<stdin>`.
    let (code, _, stderr) =
        cli::surfc_with_input(&["check", "-"], dir.path(), SPHERE.as_bytes()).bytes();
    assert_eq!(code, 0, "{stderr}");
    let (code, _, stderr) = cli::surfc_with_input(
        &["check", "-", "--color", "never"],
        dir.path(),
        b"surface s = x + qq;\n",
    )
    .bytes();
    assert_eq!(code, 1);
    assert!(stderr.contains("<stdin>:1:"), "{stderr}");
    let (code, stdout, _) = cli::surfc_with_input(
        &["eval", "-", "sphere", "2", "0", "0", "--json"],
        dir.path(),
        SPHERE.as_bytes(),
    )
    .bytes();
    assert_eq!(code, 0);
    let json: serde_json::Value = serde_json::from_slice(&stdout).expect("JSON");
    assert_eq!(json["value"], 0.0);
    assert_eq!(json["gradient"][0], 4.0);
    let (code, stdout, _) =
        cli::surfc_with_input(&["bytecode", "-", "sphere"], dir.path(), SPHERE.as_bytes()).bytes();
    assert_eq!(code, 0);
    assert!(!stdout.is_empty());
    let (code, stdout, _) =
        cli::surfc_with_input(&["fmt", "-"], dir.path(), b"surface   s=x;").bytes();
    assert_eq!(code, 0);
    assert_eq!(String::from_utf8_lossy(&stdout), "surface s = x;\n");
}

#[test]
fn fmt_check_lists_what_would_change_and_write_changes_it() {
    let dir = scratch();
    let tidy = "surface s = x;\n";
    let messy = "surface   s=x;";
    let broken = "surface s = ;\n";
    std::fs::write(dir.path().join("tidy.surf"), tidy).expect("written");
    std::fs::write(dir.path().join("messy.surf"), messy).expect("written");
    std::fs::write(dir.path().join("broken.surf"), broken).expect("written");

    let (code, stdout, _) = cli::surfc(&["fmt", "--check", "tidy.surf"], dir.path()).bytes();
    assert_eq!((code, stdout.as_slice()), (0, &b""[..]));
    let (code, stdout, _) =
        cli::surfc(&["fmt", "--check", "tidy.surf", "messy.surf"], dir.path()).bytes();
    assert_eq!(code, 1);
    assert_eq!(String::from_utf8_lossy(&stdout), "messy.surf\n");
    // --check changes nothing.
    let read = |name: &str| std::fs::read_to_string(dir.path().join(name)).expect("readable");
    assert_eq!(read("messy.surf"), messy);

    let (code, stdout, _) =
        cli::surfc(&["fmt", "--write", "tidy.surf", "messy.surf"], dir.path()).bytes();
    assert_eq!(code, 0);
    assert!(stdout.is_empty());
    assert_eq!(read("messy.surf"), tidy);
    assert_eq!(read("tidy.surf"), tidy);
    let (code, _, _) =
        cli::surfc(&["fmt", "--check", "tidy.surf", "messy.surf"], dir.path()).bytes();
    assert_eq!(code, 0);

    // A file that does not parse is an error (exit 1) and is left alone; the others are
    // still formatted.
    std::fs::write(dir.path().join("messy.surf"), messy).expect("written");
    let (code, _, stderr) =
        cli::surfc(&["fmt", "--write", "broken.surf", "messy.surf"], dir.path()).bytes();
    assert_eq!(code, 1);
    assert!(stderr.contains("broken.surf"), "{stderr}");
    assert_eq!(read("broken.surf"), broken);
    assert_eq!(read("messy.surf"), tidy);

    // Both flags, or --write on stdin, are usage errors.
    let (code, _, _) = cli::surfc(&["fmt", "--check", "--write", "tidy.surf"], dir.path()).bytes();
    assert_eq!(code, 2);
    let (code, _, _) =
        cli::surfc_with_input(&["fmt", "--write", "-"], dir.path(), messy.as_bytes()).bytes();
    assert_eq!(code, 2);
}

#[test]
fn json_failures_print_errors_on_stdout() {
    let dir = scratch();
    // Two errors in one file: both are listed, with their places.
    let text = "surface s = x + qq;\nmesh m = s { step: 0.5; start: (0, 0, 0); bogus: 1; }\n";
    std::fs::write(dir.path().join("bad.surf"), text).expect("written");
    let (code, stdout, stderr) =
        cli::surfc(&["mesh", "bad.surf", "--json", "-q"], dir.path()).bytes();
    assert_eq!(code, 1);
    // The diagnostics are on stderr as always.
    assert!(stderr.contains("qq"), "{stderr}");
    let json: serde_json::Value = serde_json::from_slice(&stdout).expect("one JSON object");
    let errors = json["errors"].as_array().expect("errors");
    assert!(errors.len() >= 2, "{json}");
    let first = &errors[0];
    for key in ["code", "severity", "message", "file", "line", "column"] {
        assert!(!first[key].is_null(), "{key} in {first}");
    }
    assert_eq!(first["file"], "bad.surf");
    assert_eq!(first["severity"], "error");
    assert!(first["code"].as_str().expect("a code").starts_with('E'));
    // `qq` is at line 1, column 17 (1-based, in characters).
    assert_eq!(
        (first["line"].as_u64(), first["column"].as_u64()),
        (Some(1), Some(17))
    );
    assert!(errors.iter().any(|e| e["line"] == 2), "{json}");

    // A missing file: an I/O error with the usual exit code 2.
    let (code, stdout, _) = cli::surfc(&["mesh", "nowhere.surf", "--json"], dir.path()).bytes();
    assert_eq!(code, 2);
    let json: serde_json::Value = serde_json::from_slice(&stdout).expect("JSON");
    assert_eq!(json["errors"][0]["code"], "io");
    assert_eq!(json["errors"][0]["file"], "nowhere.surf");
    assert!(json["errors"][0]["line"].is_null());

    // A mesh that cannot be completed: its diagnostic.
    let never = "surface s = x^2 + y^2 + z^2 - 4;\n\
                 mesh m = s { step: 0.5; start: (1, 1, 1); max_triangles: 3; }\n";
    std::fs::write(dir.path().join("never.surf"), never).expect("written");
    let (code, stdout, stderr) =
        cli::surfc(&["mesh", "never.surf", "--json", "-q"], dir.path()).bytes();
    assert_eq!(code, 1);
    let json: serde_json::Value = serde_json::from_slice(&stdout).expect("JSON");
    let error = &json["errors"][0];
    assert_eq!(error["code"], "E0601");
    assert_eq!(error["line"], 2);
    // The reason and the fix, which stderr's diagnostic gives as its note and help, are in
    // the JSON too, and so is every label with its place.
    let notes = error["notes"].as_array().expect("notes");
    assert!(!notes.is_empty(), "{error}");
    for note in notes {
        let note = note.as_str().expect("a note is text");
        assert!(
            note.contains("3") && stderr.contains(note),
            "{note}\n{stderr}"
        );
    }
    let help = error["help"].as_str().expect("a help");
    assert!(
        help.contains("max_triangles") && stderr.contains(help),
        "{help}\n{stderr}"
    );
    let labels = error["labels"].as_array().expect("labels");
    assert_eq!(labels[0]["primary"], true, "{error}");
    assert_eq!(labels[0]["message"], "this mesh block");
    assert_eq!(
        (labels[0]["line"].as_u64(), labels[0]["file"].as_str()),
        (Some(2), Some("never.surf"))
    );
    // Errors that are no diagnostic have none of them.
    let (_, stdout, _) = cli::surfc(&["mesh", "nowhere.surf", "--json"], dir.path()).bytes();
    let json: serde_json::Value = serde_json::from_slice(&stdout).expect("JSON");
    assert!(json["errors"][0]["help"].is_null());
    assert_eq!(json["errors"][0]["notes"], serde_json::json!([]));
    assert_eq!(json["errors"][0]["labels"], serde_json::json!([]));

    // eval --json too: an unknown surface, and a file with errors.
    let (code, stdout, _) = cli::surfc(
        &["eval", "never.surf", "t", "0", "0", "0", "--json"],
        dir.path(),
    )
    .bytes();
    assert_eq!(code, 1);
    let json: serde_json::Value = serde_json::from_slice(&stdout).expect("JSON");
    assert_eq!(json["errors"][0]["code"], "input");
    assert!(
        json["errors"][0]["message"]
            .as_str()
            .is_some_and(|m| m.contains("no surface `t`")),
        "{json}"
    );
    let (code, stdout, _) = cli::surfc(
        &["eval", "bad.surf", "s", "0", "0", "0", "--json"],
        dir.path(),
    )
    .bytes();
    assert_eq!(code, 1);
    let json: serde_json::Value = serde_json::from_slice(&stdout).expect("JSON");
    assert_eq!(json["errors"][0]["line"], 1);
}

#[test]
fn json_and_stats_report_the_shape_of_the_triangles() {
    let dir = scratch();
    std::fs::write(dir.path().join("ball.surf"), SPHERE).expect("written");
    let (code, stdout, stderr) = cli::surfc(
        &["mesh", "ball.surf", "--json", "--stats", "-o", "ball.obj"],
        dir.path(),
    )
    .bytes();
    assert_eq!(code, 0, "{stderr}");
    let json: serde_json::Value = serde_json::from_slice(&stdout).expect("JSON");
    let m = &json["meshes"][0];
    let get = |key: &str| {
        m[key]
            .as_f64()
            .unwrap_or_else(|| panic!("{key} missing in {m}"))
    };
    // The angle percentiles are ordered, and above the smallest angle.
    assert!(get("min_angle_deg") <= get("min_angle_p1_deg"));
    assert!(get("min_angle_p1_deg") <= get("min_angle_p5_deg"));
    assert!(get("min_angle_p5_deg") <= get("min_angle_median_deg"));
    assert!(get("min_angle_median_deg") <= 60.0);
    assert!(get("radius_ratio_min") <= get("radius_ratio_mean"));
    assert!(get("radius_ratio_mean") <= 1.0 && get("radius_ratio_min") > 0.0);
    assert!(get("edge_min") <= get("edge_mean") && get("edge_mean") <= get("edge_max"));

    // The edge lengths against the file written: an independent count over the OBJ's faces.
    let obj = std::fs::read_to_string(dir.path().join("ball.obj")).expect("ball.obj");
    let points: Vec<[f64; 3]> = obj
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f64> = l.split(' ').map(|t| t.parse().expect("a number")).collect();
            [v[0], v[1], v[2]]
        })
        .collect();
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for face in obj.lines().filter_map(|l| l.strip_prefix("f ")) {
        let corners: Vec<usize> = face
            .split(' ')
            .map(|c| {
                c.split('/')
                    .next()
                    .expect("an index")
                    .parse()
                    .expect("a number")
            })
            .collect();
        for k in 0..3 {
            let (a, b) = (points[corners[k] - 1], points[corners[(k + 1) % 3] - 1]);
            let length =
                ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
            lo = lo.min(length);
            hi = hi.max(length);
        }
    }
    assert!((get("edge_min") - lo).abs() <= 1e-12 * hi, "{lo}");
    assert!((get("edge_max") - hi).abs() <= 1e-12 * hi, "{hi}");

    // The --stats table: a header and a row for the mesh, on stderr.
    let table: Vec<&str> = stderr.lines().collect();
    let header = table
        .iter()
        .position(|l| l.starts_with("mesh") && l.contains("ratio mean"))
        .unwrap_or_else(|| panic!("no stats table in {stderr}"));
    assert!(table[header + 1].starts_with("ball "), "{stderr}");
    let cells: Vec<&str> = table[header + 1].split_whitespace().collect();
    assert_eq!(cells.len(), 10, "{stderr}");
    let shown: f64 = cells[5].parse().expect("the mean radius ratio");
    assert!((shown - get("radius_ratio_mean")).abs() <= 5e-5);
}

#[test]
fn render_draws_mesh_files_of_every_readable_format() {
    let dir = scratch();
    std::fs::write(dir.path().join("ball.surf"), SPHERE).expect("written");
    let (code, _, stderr) = cli::surfc(
        &[
            "render",
            "ball.surf",
            "-o",
            "direct.png",
            "--size",
            "120x90",
            "-q",
        ],
        dir.path(),
    )
    .bytes();
    assert_eq!(code, 0, "{stderr}");
    let direct = std::fs::read(dir.path().join("direct.png")).expect("direct.png");
    for format in ["obj", "ply", "off", "3mf", "stl", "glb"] {
        let mesh = format!("ball.{format}");
        let (code, _, stderr) =
            cli::surfc(&["mesh", "ball.surf", "-o", &mesh, "-q"], dir.path()).bytes();
        assert_eq!(code, 0, "{stderr}");
        let png = format!("{format}.png");
        let (code, _, stderr) = cli::surfc(
            &["render", &mesh, "-o", &png, "--size", "120x90"],
            dir.path(),
        )
        .bytes();
        assert_eq!(code, 0, "{format}: {stderr}");
        let picture = std::fs::read(dir.path().join(&png)).expect("the picture");
        if matches!(format, "stl" | "glb") {
            // f32 formats: a picture of the same size, not necessarily the same pixels.
            assert_eq!(
                picture[..24],
                direct[..24],
                "{format}: the PNG header and size"
            );
        } else {
            // The exact formats give back the same vertices, so the same picture.
            assert_eq!(picture, direct, "{format}");
        }
    }
    // A mesh file that is not one: exit 1 naming it; an unknown --only: exit 2.
    std::fs::write(dir.path().join("junk.obj"), b"f 1 2 3\n").expect("written");
    let (code, _, stderr) =
        cli::surfc(&["render", "junk.obj", "-o", "junk.png"], dir.path()).bytes();
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("junk.obj"), "{stderr}");
    let (code, _, stderr) = cli::surfc(
        &["render", "ball.obj", "-o", "x.png", "--only", "nope"],
        dir.path(),
    )
    .bytes();
    assert_eq!(code, 2);
    assert!(stderr.contains("ball"), "{stderr}");
}
