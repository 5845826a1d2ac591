//! The generated CAD-part sweep of issue 42 (must-show 3): parts nobody tuned for — plates
//! with flush, through and blind holes, L/T/U brackets of boxes sharing faces, stacked
//! blocks, bosses and ribs, fillets by `smooth_union` and by `offset`, overlapping scatters,
//! flanges of turned copies, rod lattices, and any of these turned and moved
//! (`common::cad`) — each meshed through the `surfc` binary with a `box` and no `start` at ½,
//! 1, 2½ and 3 times its smallest feature, with a time limit of 60 s a run.
//!
//! Every run is one of:
//! - **right**: exit 0, watertight, consistently oriented, no crossing triangles
//!   (`surfc::mesh::check`), facing out (positive volume, no triangle facing against the
//!   native gradient), every vertex on the native solid (|f|/|∇f| ≤ 1e-6·step), χ and
//!   surface components those of the voxel reference (which agrees with the construction
//!   where it knows them), extent, volume and area within tolerance of the reference;
//! - **refused** with a place: exit 1 with a diagnostic that has a code and a span (`--json`'s
//!   line and column; whether the message names a point is counted too);
//! - **wrong**: exit 0 but not right — a wrong mesh reported as success, the worst bug;
//! - **over 60 s**: killed at the limit;
//! - **crash**: an exit code other than 0 and 1, or a panic;
//! - **skipped**: exit 0, the reference-free checks pass, but the reference cannot be trusted
//!   (no two grids agree): never counted as right;
//! - **unplaced**: exit 1 without a code and a span.
//!
//! The right meshes' quality is measured against docs/quality.md's bars: every triangle ≥ 30°
//! except at a crease corner (a vertex where three or more sharp edges meet) whose face
//! sector there is narrower than 60°, and a mean radius ratio ≥ 0.97.
//!
//! Asserted always: no wrong mesh, no crash, no run over the limit. With `SURFC_CAD_STRICT=1`
//! also: every run at ½ feature right (at most 5 % skipped), no unplaced refusal, and the
//! quality bars for every right mesh. Variables (tests/README.md): `SURFC_CAD_CASES=N` parts
//! (default 9, one of each class), `SURFC_CAD_SEED=S`, `SURFC_CAD_ONLY=K` (part K alone),
//! `SURFC_CAD_CLASS=NAME` (one class), `SURFC_CAD_DUMP=DIR` (keeps the sources of wrong,
//! crashing, timed-out, refused and unplaced runs), `SURFC_CAD_BIN=PATH` (another binary,
//! e.g. `target/release/surfc`), `SURFC_CAD_TIMEOUT=S` (the limit, default 60),
//! `SURFC_CAD_STRICT=1`.

use crate::common;

use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::cad::{self, Class, Part, Reference};
use common::rng::Rng;
use glam::DVec3;
use rayon::prelude::*;
use surfc::mesh::Mesh;
use surfc::mesh::check::{Expect, check};

/// The steps, as multiples of the part's smallest feature.
pub const MULTIPLES: [f64; 4] = [0.5, 1.0, 2.5, 3.0];

/// A triangle angle below this is a quality failure, unless exempt at a crease corner.
const ANGLE: f64 = 30.0;
/// A crease corner's face sector narrower than this exempts its triangles from `ANGLE`.
const CORNER: f64 = 60.0;
/// Two triangles whose normals differ by more than this meet at a sharp edge.
const SHARP: f64 = 35.0;
/// The mean radius ratio every right mesh reaches (docs/quality.md).
const RATIO: f64 = 0.97;

/// Whether `SURFC_CAD_STRICT=1`: the bars the crease rework is to meet.
pub fn strict() -> bool {
    std::env::var("SURFC_CAD_STRICT").is_ok_and(|v| v == "1")
}

/// The binary: `SURFC_CAD_BIN`, or the one cargo built for the tests.
fn binary() -> PathBuf {
    std::env::var_os("SURFC_CAD_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_surfc")))
}

/// The time limit of one run (`SURFC_CAD_TIMEOUT` seconds, default 60).
fn limit() -> Duration {
    Duration::from_secs_f64(common::env_number("SURFC_CAD_TIMEOUT").unwrap_or(60.0))
}

/// What one run of the binary gave.
pub struct Run {
    /// None when killed (by the limit or a signal).
    pub code: Option<i32>,
    pub stdout: Vec<u8>,
    pub stderr: String,
    pub seconds: f64,
    pub timed_out: bool,
}

/// Runs `surfc ARGS` in `dir`, killing it at `limit`.
pub fn run_with_limit(args: &[&str], dir: &Path, limit: Duration) -> Run {
    let started = Instant::now();
    let mut child = Command::new(binary())
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("surfc runs");
    let mut out = child.stdout.take().expect("a stdout pipe");
    let mut err = child.stderr.take().expect("a stderr pipe");
    let out = std::thread::spawn(move || {
        let mut v = Vec::new();
        let _ = out.read_to_end(&mut v);
        v
    });
    let err = std::thread::spawn(move || {
        let mut v = Vec::new();
        let _ = err.read_to_end(&mut v);
        v
    });
    let mut timed_out = false;
    let status = loop {
        if let Some(status) = child.try_wait().expect("surfc is waited for") {
            break status;
        }
        if started.elapsed() > limit {
            let _ = child.kill();
            timed_out = true;
            break child.wait().expect("surfc is waited for");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let seconds = started.elapsed().as_secs_f64();
    Run {
        code: status.code(),
        stdout: out.join().unwrap_or_default(),
        stderr: String::from_utf8_lossy(&err.join().unwrap_or_default()).into_owned(),
        seconds,
        timed_out,
    }
}

/// The outcome of one run.
#[derive(Clone, Debug)]
pub enum Outcome {
    Right,
    /// Exit 1 with a code and a span; `point` when a message names a point in space.
    Refused {
        code: String,
        note: String,
        point: bool,
    },
    /// Exit 1 without a code and a span.
    Unplaced(String),
    Wrong(String),
    Timeout,
    Crash(String),
    /// The mesh passed what can be checked without the reference, which cannot be trusted.
    Skipped(String),
}

impl Outcome {
    pub fn name(&self) -> &'static str {
        match self {
            Outcome::Right => "right",
            Outcome::Refused { .. } => "refused",
            Outcome::Unplaced(_) => "unplaced",
            Outcome::Wrong(_) => "wrong",
            Outcome::Timeout => "timeout",
            Outcome::Crash(_) => "crash",
            Outcome::Skipped(_) => "skipped",
        }
    }
}

/// The quality of a right mesh.
#[derive(Clone, Debug)]
pub struct Quality {
    pub triangles: usize,
    /// The smallest angle of any triangle, degrees.
    pub min_angle: f64,
    /// The smallest angle of the triangles the corner exemption does not cover.
    pub min_unexempt: f64,
    /// Triangles below 30° that the exemption covers.
    pub exempt: usize,
    pub radius_ratio: f64,
}

impl Quality {
    /// Why the mesh misses the bars, if it does.
    pub fn failure(&self) -> Option<String> {
        let mut why = Vec::new();
        if self.min_unexempt < ANGLE {
            why.push(format!(
                "a triangle of {:.1}° not at a sharp crease corner",
                self.min_unexempt
            ));
        }
        if self.radius_ratio < RATIO {
            why.push(format!("mean radius ratio {:.4}", self.radius_ratio));
        }
        (!why.is_empty()).then(|| why.join(", "))
    }
}

/// One run judged.
pub struct Judged {
    pub outcome: Outcome,
    pub seconds: f64,
    pub mesh: Option<Mesh>,
    pub quality: Option<Quality>,
    /// The `--json` report (of the mesh, or of the errors).
    pub json: Option<serde_json::Value>,
    pub stderr: String,
    pub source: String,
}

/// The vertices and triangles of an OBJ file as surfc writes it (`v`, `vn`, `f a//a …`),
/// welded by position: at a sharp edge surfc writes one `v` per side, bit-identical
/// positions with their own normals (docs/formats.md, *Sharp edges*), which a reader of the
/// geometry merges as `trimesh`'s `merge_vertices(merge_norm=True)` does.
fn read_obj(path: &Path) -> Result<Mesh, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("no OBJ file: {e}"))?;
    let mut mesh = Mesh::default();
    // Each `v` line's index into the welded vertices.
    let mut welded: Vec<u32> = Vec::new();
    let mut seen: std::collections::HashMap<[u64; 3], u32> = std::collections::HashMap::new();
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let c: Vec<f64> = words.map(|w| w.parse().unwrap_or(f64::NAN)).collect();
                if c.len() != 3 {
                    return Err(format!("bad vertex line {line:?}"));
                }
                let p = DVec3::new(c[0], c[1], c[2]);
                let next = mesh.vertices.len() as u32;
                let k = *seen.entry(p.to_array().map(f64::to_bits)).or_insert(next);
                if k == next {
                    mesh.vertices.push(p);
                }
                welded.push(k);
            }
            Some("f") => {
                let k: Vec<u32> = words
                    .map(|w| {
                        w.split('/')
                            .next()
                            .and_then(|i| i.parse::<u32>().ok())
                            .map_or(u32::MAX, |i| i.wrapping_sub(1))
                    })
                    .collect();
                if k.len() != 3 || k.iter().any(|&i| i as usize >= welded.len()) {
                    return Err(format!("bad face line {line:?}"));
                }
                mesh.triangles
                    .push([k[0], k[1], k[2]].map(|i| welded[i as usize]));
            }
            _ => {}
        }
    }
    Ok(mesh)
}

/// The native gradient of the part's function at p (central differences).
fn gradient(part: &Part, p: DVec3) -> DVec3 {
    let e = 1e-7;
    DVec3::new(
        part.value(p + DVec3::X * e) - part.value(p - DVec3::X * e),
        part.value(p + DVec3::Y * e) - part.value(p - DVec3::Y * e),
        part.value(p + DVec3::Z * e) - part.value(p - DVec3::Z * e),
    ) / (2.0 * e)
}

/// The mesh's signed volume (divergence theorem) and area.
pub fn volume_and_area(mesh: &Mesh) -> (f64, f64) {
    let (mut volume, mut area) = (0.0, 0.0);
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|k| mesh.vertices[k as usize]);
        volume += a.dot(b.cross(c)) / 6.0;
        area += 0.5 * (b - a).cross(c - a).length();
    }
    (volume, area)
}

/// Meshes `part` at `step` (`multiple` times its feature) through the binary in `dir` and
/// judges the run; `reference` caches the part's voxel reference (made at the first mesh
/// that needs it).
pub fn judge(
    part: &Part,
    step: f64,
    multiple: f64,
    dir: &Path,
    reference: &mut Option<Result<Reference, String>>,
) -> Judged {
    let source = part.source(step);
    let input = dir.join("part.surf");
    let output = dir.join("part.obj");
    std::fs::write(&input, &source).expect("writes the part");
    let _ = std::fs::remove_file(&output);
    let run = run_with_limit(
        &["mesh", "part.surf", "--json", "-o", "part.obj"],
        dir,
        limit(),
    );
    let json: Option<serde_json::Value> = serde_json::from_slice(&run.stdout).ok();
    let mut judged = Judged {
        outcome: Outcome::Right,
        seconds: run.seconds,
        mesh: None,
        quality: None,
        json,
        stderr: run.stderr,
        source,
    };
    judged.outcome = if run.timed_out {
        Outcome::Timeout
    } else if judged.stderr.contains("panicked") || !matches!(run.code, Some(0 | 1)) {
        Outcome::Crash(format!(
            "exit {:?}: {}",
            run.code,
            judged
                .stderr
                .lines()
                .take(6)
                .collect::<Vec<_>>()
                .join(" | ")
        ))
    } else if run.code == Some(1) {
        refusal(judged.json.as_ref(), &judged.stderr)
    } else {
        match read_obj(&output) {
            Err(e) => Outcome::Wrong(format!("exit 0 without a readable mesh: {e}")),
            Ok(mesh) => {
                let warnings = judged
                    .json
                    .as_ref()
                    .and_then(|j| j["meshes"][0]["warnings"].as_array().cloned())
                    .unwrap_or_default();
                let outcome = compare_mesh(part, &mesh, step, multiple, reference);
                let outcome = match outcome {
                    Outcome::Wrong(why) if !warnings.is_empty() => {
                        Outcome::Wrong(format!("{why} (surfc warned: {warnings:?})"))
                    }
                    o => o,
                };
                if matches!(outcome, Outcome::Right) {
                    judged.quality = Some(quality(&mesh));
                }
                judged.mesh = Some(mesh);
                outcome
            }
        }
    };
    let _ = std::fs::remove_file(&output);
    judged
}

/// An exit 1: refused with a place when `--json` has an error with a code, a line and a
/// column.
fn refusal(json: Option<&serde_json::Value>, stderr: &str) -> Outcome {
    let first = json
        .and_then(|j| j["errors"].as_array())
        .and_then(|e| e.first());
    let code = first
        .and_then(|e| e["code"].as_str())
        .unwrap_or("")
        .to_string();
    let placed =
        first.is_some_and(|e| e["line"].as_u64().is_some() && e["column"].as_u64().is_some());
    // The diagnostic's notes say what happened and where.
    let notes: Vec<&str> = stderr
        .lines()
        .filter_map(|l| l.trim_start().strip_prefix("= note:"))
        .map(str::trim)
        .collect();
    let message = first
        .and_then(|e| e["message"].as_str())
        .unwrap_or("")
        .to_string();
    let note = if notes.is_empty() {
        message
    } else {
        notes.join(" / ")
    };
    if code.is_empty() || !placed {
        return Outcome::Unplaced(stderr.lines().take(8).collect::<Vec<_>>().join(" | "));
    }
    Outcome::Refused {
        code,
        point: names_a_point(stderr),
        note,
    }
}

/// Whether the text has a point `[x, y, z]` of three numbers.
fn names_a_point(text: &str) -> bool {
    text.split('[').skip(1).any(|rest| {
        rest.split(']').next().is_some_and(|inside| {
            let parts: Vec<&str> = inside.split(',').map(str::trim).collect();
            parts.len() == 3 && parts.iter().all(|p| p.parse::<f64>().is_ok())
        })
    })
}

/// The checks of an exit 0 (module documentation): Right, Wrong or Skipped.
pub fn compare_mesh(
    part: &Part,
    mesh: &Mesh,
    step: f64,
    multiple: f64,
    reference: &mut Option<Result<Reference, String>>,
) -> Outcome {
    let expect = Expect {
        closed: true,
        boundary_loops: Some(0),
        min_angle_deg: 0.0,
        ..Expect::default()
    };
    let (topology, violations) = check(mesh, None, &expect);
    if !violations.is_empty() {
        return Outcome::Wrong(format!("{violations:?}"));
    }
    for &p in &mesh.vertices {
        // On the surface exactly, the distance is 0 even where the central differences of a
        // min/max cancel (a vertex at a concave corner of stacked blocks).
        let value = part.value(p).abs();
        let off = if value == 0.0 {
            0.0
        } else {
            value / gradient(part, p).length()
        };
        if off.is_nan() || off > 1e-6 * step {
            return Outcome::Wrong(format!("vertex {p} is {off:.1e} off the surface"));
        }
    }
    // Facing: a triangle whose normal is more than 120° from the native gradient at its
    // centroid faces in (one across a crease is at most about 90° off).
    let mut against = 0;
    let mut first = None;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|k| mesh.vertices[k as usize]);
        let n = (b - a).cross(c - a);
        let g = gradient(part, (a + b + c) / 3.0);
        if n.dot(g) < -0.5 * n.length() * g.length() {
            against += 1;
            first.get_or_insert((a + b + c) / 3.0);
        }
    }
    if let Some(at) = first {
        return Outcome::Wrong(format!(
            "{against} triangles face against the gradient, the first at {at}"
        ));
    }
    let (volume, area) = volume_and_area(mesh);
    if volume <= 0.0 {
        return Outcome::Wrong(format!("the mesh's volume is {volume}: it faces in"));
    }
    let r = match reference.get_or_insert_with(|| cad::reference(part)) {
        Ok(r) => r.clone(),
        Err(why) => return Outcome::Skipped(why.clone()),
    };
    if topology.euler_characteristic != r.euler || topology.components != r.components {
        return Outcome::Wrong(format!(
            "χ {} and {} components, the reference has χ {} and {} components",
            topology.euler_characteristic, topology.components, r.euler, r.components
        ));
    }
    // The extent: the mesh reaches the reference's inside vertices (less the chord
    // tolerance) and stays within three voxels of them: a box's corner turned to point along
    // a diagonal holds no grid vertex within about 2.4 voxels of its apex (the ball of
    // radius √3/2 voxels that surely holds one fits that deep into the corner only), and the
    // reference rounds creases of scatters by two voxels.
    let (lo, hi) = mesh
        .triangles
        .iter()
        .flatten()
        .map(|&k| mesh.vertices[k as usize])
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p), hi.max(p))
        });
    let chord = 1e-9 + 0.1 * step;
    let outer = 3.0 * r.voxel + chord;
    for a in 0..3 {
        let reaches = lo[a] <= r.lo[a] + chord && hi[a] >= r.hi[a] - chord;
        let within = lo[a] >= r.lo[a] - outer && hi[a] <= r.hi[a] + outer;
        if !reaches || !within {
            return Outcome::Wrong(format!(
                "extent on axis {a}: mesh {}..{}, reference inside {}..{} (voxel {})",
                lo[a], hi[a], r.lo[a], r.hi[a], r.voxel
            ));
        }
    }
    // The volume: the grid's is the true one to within a voxel over the surface, the mesh's
    // to within the chord tolerance over it.
    if (volume - r.volume).abs() > area * (r.voxel + 0.1 * step) {
        return Outcome::Wrong(format!(
            "volume {volume} against the reference's {} (area {area})",
            r.volume
        ));
    }
    // The area: chords cut curved faces short by about a third of their sag over the
    // radius (3.5 % of the area a step multiple at most, curved radii being at least a
    // feature), and the shell estimate is good to a few percent.
    let slack = 0.03 + 0.035 * multiple;
    if (area - r.area).abs() > slack * r.area {
        return Outcome::Wrong(format!(
            "area {area} against the reference's {} (± {:.0} %)",
            r.area,
            100.0 * slack
        ));
    }
    Outcome::Right
}

/// The quality of a closed, consistently oriented mesh (module documentation).
pub fn quality(mesh: &Mesh) -> Quality {
    let v = &mesh.vertices;
    let tris = &mesh.triangles;
    let angles: Vec<[f64; 3]> = tris
        .iter()
        .map(|t| {
            let p = t.map(|k| v[k as usize]);
            std::array::from_fn(|i| {
                let (a, b, c) = (p[i], p[(i + 1) % 3], p[(i + 2) % 3]);
                (b - a).angle_between(c - a).to_degrees()
            })
        })
        .collect();
    let normals: Vec<DVec3> = tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|k| v[k as usize]);
            (b - a).cross(c - a).normalize_or_zero()
        })
        .collect();
    let mut ratio = 0.0;
    for t in tris {
        let [a, b, c] = t.map(|k| v[k as usize]);
        let (x, y, z) = (a.distance(b), b.distance(c), c.distance(a));
        let area = 0.5 * (b - a).cross(c - a).length();
        let s = 0.5 * (x + y + z);
        let product = s * x * y * z;
        ratio += if product > 0.0 {
            8.0 * area * area / product
        } else {
            0.0
        };
    }
    // Edges with their triangles; sharp where the normals differ by more than SHARP.
    let mut edges: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for (i, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.entry((a.min(b), a.max(b))).or_default().push(i);
        }
    }
    let sharp = |a: u32, b: u32| {
        edges.get(&(a.min(b), a.max(b))).is_some_and(|ts| {
            ts.len() == 2 && normals[ts[0]].angle_between(normals[ts[1]]).to_degrees() > SHARP
        })
    };
    let mut sharp_at = vec![0usize; v.len()];
    for (&(a, b), ts) in &edges {
        if ts.len() == 2 && sharp(a, b) {
            sharp_at[a as usize] += 1;
            sharp_at[b as usize] += 1;
        }
    }
    // The face sector at corner `c` that holds triangle `t`: its angle at c, walked round c
    // both ways to the sharp edges that bound it.
    let sector = |t: usize, c: u32| -> f64 {
        let corner = |t: usize| tris[t].iter().position(|&k| k == c).expect("a corner");
        let mut total = angles[t][corner(t)];
        for side in [1, 2] {
            let (mut at, mut other) = (t, tris[t][(corner(t) + side) % 3]);
            loop {
                if sharp(c, other) {
                    break;
                }
                let Some(&next) = edges[&(c.min(other), c.max(other))]
                    .iter()
                    .find(|&&u| u != at)
                else {
                    break;
                };
                if next == t {
                    // Round the whole fan without a sharp edge: no corner.
                    return 360.0;
                }
                total += angles[next][corner(next)];
                let k = corner(next);
                let (p, q) = (tris[next][(k + 1) % 3], tris[next][(k + 2) % 3]);
                other = if p == other { q } else { p };
                at = next;
            }
        }
        total
    };
    let (mut min_angle, mut min_unexempt, mut exempt) = (f64::INFINITY, f64::INFINITY, 0);
    for (i, t) in tris.iter().enumerate() {
        let smallest = angles[i].iter().copied().fold(f64::INFINITY, f64::min);
        min_angle = min_angle.min(smallest);
        if smallest >= ANGLE {
            min_unexempt = min_unexempt.min(smallest);
            continue;
        }
        if t.iter()
            .any(|&c| sharp_at[c as usize] >= 3 && sector(i, c) < CORNER)
        {
            exempt += 1;
        } else {
            min_unexempt = min_unexempt.min(smallest);
        }
    }
    Quality {
        triangles: tris.len(),
        min_angle,
        min_unexempt,
        exempt,
        radius_ratio: ratio / tris.len().max(1) as f64,
    }
}

/// The sweep's seed unless `SURFC_CAD_SEED` gives another.
pub const SEED: u64 = 0x0042_CAD0_5EED;

/// The generator of part `case` of the sweep drawn from `seed`: its own stream, so that one
/// part can be drawn alone.
pub fn case_rng(seed: u64, case: usize) -> Rng {
    Rng::new(seed ^ (case as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// The counts of one class at one step multiple.
#[derive(Clone, Copy, Default)]
struct Counts {
    runs: usize,
    right: usize,
    refused: usize,
    refused_with_point: usize,
    wrong: usize,
    timeout: usize,
    crash: usize,
    skipped: usize,
    unplaced: usize,
    quality: usize,
    slowest: f64,
}

impl Counts {
    fn add(&mut self, o: &Counts) {
        self.runs += o.runs;
        self.right += o.right;
        self.refused += o.refused;
        self.refused_with_point += o.refused_with_point;
        self.wrong += o.wrong;
        self.timeout += o.timeout;
        self.crash += o.crash;
        self.skipped += o.skipped;
        self.unplaced += o.unplaced;
        self.quality += o.quality;
        self.slowest = self.slowest.max(o.slowest);
    }

    fn row(&self, label: &str) -> String {
        format!(
            "{label:<22} {:>5} {:>6} {:>8} ({:>4}) {:>6} {:>5} {:>6} {:>8} {:>9} {:>9} {:>8.1}",
            self.runs,
            self.right,
            self.refused,
            self.refused_with_point,
            self.wrong,
            self.timeout,
            self.crash,
            self.skipped,
            self.unplaced,
            self.quality,
            self.slowest
        )
    }
}

/// A refusal's note with its numbers taken out, to group refusals by kind.
fn kind_of(note: &str) -> String {
    let mut out = String::new();
    let mut in_number = false;
    for ch in note.chars() {
        let numeric = ch.is_ascii_digit() || (in_number && (ch == '.' || ch == 'e'));
        if numeric {
            if !in_number {
                if out.ends_with('-') {
                    out.pop();
                }
                out.push('#');
            }
            in_number = true;
        } else {
            in_number = false;
            out.push(ch);
        }
    }
    out.replace("[#, #, #]", "P")
}

/// One run of a part in the sweep: at one multiple of its smallest feature, judged.
struct PartRun {
    /// The multiple's place in `MULTIPLES`.
    mi: usize,
    multiple: f64,
    step: f64,
    judged: Judged,
    /// The reference's summary, on the run that computed it.
    reference_note: Option<String>,
}

/// Must-show 3: the generated sweep (module documentation).
#[test]
#[ignore = "long run: `.ci/run` runs it with SURFC_CAD_CASES=18 (cargo test -- --include-ignored cad_sweep::)"]
fn generated_parts_mesh_right_or_refuse_with_a_place() {
    let cases: usize = common::env_number("SURFC_CAD_CASES").unwrap_or(Class::ALL.len());
    let seed: u64 = common::env_number("SURFC_CAD_SEED").unwrap_or(SEED);
    let only: Option<usize> = common::env_number("SURFC_CAD_ONLY");
    let class: Option<Class> = std::env::var("SURFC_CAD_CLASS")
        .ok()
        .map(|name| Class::from_name(&name).unwrap_or_else(|| panic!("no class {name:?}")));
    let dump = std::env::var_os("SURFC_CAD_DUMP").map(PathBuf::from);
    if let Some(d) = &dump {
        std::fs::create_dir_all(d).expect("the dump directory");
    }
    let strict = strict();
    let dir = common::cli::scratch("cad-sweep");
    let started = Instant::now();
    let mut table: BTreeMap<(Class, usize), Counts> = BTreeMap::new();
    let mut refusals: BTreeMap<String, (usize, String)> = BTreeMap::new();
    let mut wrong: Vec<String> = Vec::new();
    let mut failures: Vec<String> = Vec::new();
    let mut lowest = (f64::INFINITY, f64::INFINITY);
    let chosen: Vec<(usize, Class)> = (0..cases)
        .map(|case| (case, Class::ALL[case % Class::ALL.len()]))
        .filter(|&(case, this)| only.is_none_or(|k| k == case) && class.is_none_or(|c| c == this))
        .collect();
    let parts = chosen.len();
    // The parts judged side by side on the rayon pool, each in a folder of its own (most of
    // a part's time is its voxel reference and the comparison, on one thread), then reported
    // in order: the same lines, tables and verdicts as one after another.
    let judged_parts: Vec<(usize, Class, String, Vec<PartRun>)> = chosen
        .par_iter()
        .map(|&(case, this)| {
            let drawn = Instant::now();
            let part = cad::generate(this, &mut case_rng(seed, case));
            let header = format!(
                "part {case} ({}): {}; smallest feature {} (drawn in {:.2} s)",
                this.name(),
                part.what,
                part.feature,
                drawn.elapsed().as_secs_f64()
            );
            let here = dir.join(format!("part{case}"));
            std::fs::create_dir_all(&here).expect("the part's scratch folder");
            let mut reference = None;
            let runs = MULTIPLES
                .iter()
                .enumerate()
                .map(|(mi, &multiple)| {
                    let step = part.step(multiple);
                    let had_reference = reference.is_some();
                    let judged = judge(&part, step, multiple, &here, &mut reference);
                    // What the reference was, said once (by the run that made it).
                    let reference_note = match (&reference, had_reference) {
                        (Some(Ok(r)), false) => Some(format!(
                            " [reference: χ {}, {} components, voxel {:.4}]",
                            r.euler, r.components, r.voxel
                        )),
                        (Some(Err(_)), false) => Some(" [no reference]".to_string()),
                        _ => None,
                    };
                    PartRun {
                        mi,
                        multiple,
                        step,
                        judged,
                        reference_note,
                    }
                })
                .collect();
            (case, this, header, runs)
        })
        .collect();
    for (case, this, header, runs) in judged_parts {
        println!("{header}");
        for run in runs {
            let PartRun {
                mi,
                multiple,
                step,
                judged,
                reference_note,
            } = run;
            let count = table.entry((this, mi)).or_default();
            count.runs += 1;
            count.slowest = count.slowest.max(judged.seconds);
            let label = format!("part {case} ({}) at {multiple}× (step {step})", this.name());
            let mut line = format!(
                "  {multiple}×: {} in {:.2} s",
                judged.outcome.name(),
                judged.seconds
            );
            match &judged.outcome {
                Outcome::Right => {
                    count.right += 1;
                    let q = judged.quality.as_ref().expect("a right mesh's quality");
                    lowest = (lowest.0.min(q.min_unexempt), lowest.1.min(q.radius_ratio));
                    line += &format!(
                        ", {} triangles, smallest angle {:.1}° ({:.1}° away from sharp corners, {} exempt there), mean radius ratio {:.4}",
                        q.triangles, q.min_angle, q.min_unexempt, q.exempt, q.radius_ratio
                    );
                    if let Some(why) = q.failure() {
                        count.quality += 1;
                        line += &format!(" — QUALITY: {why}");
                        failures.push(format!("{label}: quality: {why}"));
                    }
                }
                Outcome::Refused { code, note, point } => {
                    count.refused += 1;
                    count.refused_with_point += *point as usize;
                    line += &format!(": {code} {note}");
                    let entry = refusals
                        .entry(format!("{code} {}", kind_of(note)))
                        .or_insert((0, label.clone()));
                    entry.0 += 1;
                    if strict && multiple <= 0.5 {
                        failures.push(format!("{label}: refused: {note}"));
                    }
                }
                Outcome::Unplaced(why) => {
                    count.unplaced += 1;
                    line += &format!(": {why}");
                    failures.push(format!("{label}: exit 1 without a place: {why}"));
                }
                Outcome::Wrong(why) => {
                    count.wrong += 1;
                    line += &format!(
                        ": A WRONG MESH REPORTED AS SUCCESS: {why}\n{}",
                        judged.source
                    );
                    wrong.push(format!("{label}: {why}"));
                }
                Outcome::Timeout => {
                    count.timeout += 1;
                    wrong.push(format!("{label}: over {} s", limit().as_secs_f64()));
                }
                Outcome::Crash(why) => {
                    count.crash += 1;
                    line += &format!(": {why}");
                    wrong.push(format!("{label}: crash: {why}"));
                }
                Outcome::Skipped(why) => {
                    count.skipped += 1;
                    line += &format!(": {why}");
                }
            }
            if let Some(note) = reference_note {
                line += &note;
            }
            println!("{line}");
            // Dumped: every run not right, and right runs below the quality bars (as
            // `…_quality.surf`).
            let poor = matches!(judged.outcome, Outcome::Right)
                && judged
                    .quality
                    .as_ref()
                    .is_some_and(|q| q.failure().is_some());
            if let (Some(d), true) = (
                &dump,
                poor || !matches!(judged.outcome, Outcome::Right | Outcome::Skipped(_)),
            ) {
                let name = if poor {
                    "quality"
                } else {
                    judged.outcome.name()
                };
                let path = d.join(format!("{case:04}_{}_{multiple}_{name}.surf", this.name()));
                let why = match &judged.outcome {
                    Outcome::Refused { code, note, .. } => format!("{code} {note}"),
                    Outcome::Wrong(w) | Outcome::Crash(w) | Outcome::Unplaced(w) => w.clone(),
                    o => o.name().to_string(),
                };
                let text = format!("// {}: {why}\n{}", judged.outcome.name(), judged.source);
                std::fs::write(path, text).expect("writes the dumped case");
            }
        }
    }
    // The table.
    println!(
        "\nCAD sweep: {parts} parts (seed {seed:#x}), {} runs, {:.1} s{}",
        table.values().map(|c| c.runs).sum::<usize>(),
        started.elapsed().as_secs_f64(),
        if strict { ", strict" } else { "" }
    );
    println!(
        "{:<22} {:>5} {:>6} {:>8} {:>6} {:>6} {:>5} {:>6} {:>8} {:>9} {:>9} {:>8}",
        "class × feature",
        "runs",
        "right",
        "refused",
        "(point)",
        "wrong",
        ">60s",
        "crash",
        "skipped",
        "unplaced",
        "quality✗",
        "slowest"
    );
    let mut by_multiple = [Counts::default(); 4];
    for c in Class::ALL {
        for (mi, m) in MULTIPLES.iter().enumerate() {
            if let Some(count) = table.get(&(c, mi)) {
                println!("{}", count.row(&format!("{} {m}×", c.name())));
                by_multiple[mi].add(count);
            }
        }
    }
    let mut total = Counts::default();
    for (mi, m) in MULTIPLES.iter().enumerate() {
        println!("{}", by_multiple[mi].row(&format!("all {m}×")));
        total.add(&by_multiple[mi]);
    }
    println!("{}", total.row("all"));
    if total.right > 0 {
        println!(
            "right meshes: smallest angle outside sharp corners {:.1}°, lowest mean radius ratio {:.4}",
            lowest.0, lowest.1
        );
    }
    let mut kinds: Vec<(String, (usize, String))> = refusals.into_iter().collect();
    kinds.sort_by(|a, b| b.1.0.cmp(&a.1.0).then(a.0.cmp(&b.0)));
    println!("refusals by kind ({} kinds):", kinds.len());
    for (kind, (n, example)) in kinds.iter().take(15) {
        println!("  {n:>5}  {kind}  (e.g. {example})");
    }
    assert!(
        wrong.is_empty(),
        "wrong meshes, crashes or runs over the limit: {wrong:#?}"
    );
    if strict {
        let half = &by_multiple[0];
        assert!(
            20 * half.skipped <= half.runs,
            "{} of {} runs at ½ feature unchecked (no reference)",
            half.skipped,
            half.runs
        );
        assert!(failures.is_empty(), "strict: {failures:#?}");
    }
}
