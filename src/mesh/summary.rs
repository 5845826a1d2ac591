//! What `surfc mesh` tells a person on stderr: a progress bar while a slow mesh is being
//! made, a short table afterwards (mesh, triangles, time, topology), and with `--stats` a
//! table of shape statistics. The numbers are computed elsewhere; this module only shows
//! them.

use std::io::IsTerminal;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::thread::JoinHandle;
use std::time::Duration;

use glam::DVec3;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use super::quality::MeshReport;

/// One row of the summary table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshSummary<'a> {
    pub name: &'a str,
    pub triangles: usize,
    /// Connected components of the mesh.
    pub components: usize,
    /// Wall-clock time to make the mesh, in seconds.
    pub seconds: f64,
    /// Closed polygons of edges that belong to one triangle only.
    pub boundary_loops: usize,
    /// Edges that belong to more than two triangles.
    pub non_manifold_edges: usize,
}

/// The summary table, one line per mesh after a header line, columns aligned, ending in a
/// newline. Topology reads `watertight` for a closed manifold mesh, else counts its boundary
/// loops and non-manifold edges.
pub fn format_summary(rows: &[MeshSummary]) -> String {
    let header = ["mesh", "triangles", "components", "time", "topology"].map(String::from);
    let lines: Vec<[String; 5]> = rows
        .iter()
        .map(|r| {
            [
                r.name.to_owned(),
                r.triangles.to_string(),
                r.components.to_string(),
                duration(r.seconds),
                topology(r),
            ]
        })
        .collect();
    // Names and topology to the left, numbers to the right.
    aligned(&header, &lines, &[0, 4])
}

fn duration(seconds: f64) -> String {
    if seconds < 1.0 {
        format!("{:.0} ms", seconds * 1000.0)
    } else {
        format!("{seconds:.2} s")
    }
}

fn topology(r: &MeshSummary) -> String {
    let plural = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    match (r.boundary_loops, r.non_manifold_edges) {
        (0, 0) => "watertight".to_owned(),
        (loops, 0) => plural(loops, "boundary loop"),
        (loops, bad) => format!(
            "{}, {}",
            plural(loops, "boundary loop"),
            plural(bad, "non-manifold edge")
        ),
    }
}

/// How long a mesh may take before its progress bar appears.
const SPINNER_DELAY: Duration = Duration::from_millis(500);
/// How often a visible progress bar redraws.
const SPINNER_TICK: Duration = Duration::from_millis(100);

/// A progress bar for one mesh: the triangles made so far (read from a counter the marcher
/// updates) and, where there is an estimate, a bar towards it. It appears only if the mesh
/// takes longer than half a second, only when stderr is a terminal, never when quiet; it
/// vanishes when finished or dropped.
pub struct Progress {
    bar: ProgressBar,
    /// The marcher's triangle count.
    counter: Arc<AtomicU64>,
    /// Tells the timer thread that the mesh is done.
    done: Option<mpsc::Sender<()>>,
    timer: Option<JoinHandle<()>>,
}

impl Progress {
    /// Starts timing the mesh called `name`, expected to have about `estimate` triangles.
    pub fn start(name: &str, quiet: bool, estimate: Option<u64>) -> Progress {
        let bar = ProgressBar::with_draw_target(estimate, ProgressDrawTarget::hidden());
        let template = if estimate.is_some() {
            "{spinner} meshing {msg}: {pos} of ~{len} triangles [{bar:30}] ({elapsed})"
        } else {
            "{spinner} meshing {msg}: {pos} triangles ({elapsed})"
        };
        if let Ok(style) = ProgressStyle::with_template(template) {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_message(name.to_owned());
        let counter = Arc::new(AtomicU64::new(0));
        if quiet || !std::io::stderr().is_terminal() {
            return Progress {
                bar,
                counter,
                done: None,
                timer: None,
            };
        }
        let (done, wait) = mpsc::channel::<()>();
        let shown = bar.clone();
        let count = Arc::clone(&counter);
        let timer = std::thread::spawn(move || {
            if wait.recv_timeout(SPINNER_DELAY) != Err(RecvTimeoutError::Timeout) {
                return;
            }
            shown.set_draw_target(ProgressDrawTarget::stderr());
            while wait.recv_timeout(SPINNER_TICK) == Err(RecvTimeoutError::Timeout) {
                let made = count.load(Ordering::Relaxed);
                // An estimate is only that: past it, the bar stays full and keeps counting.
                if shown.length().is_some_and(|len| made > len) {
                    shown.set_length(made);
                }
                shown.set_position(made);
                shown.tick();
            }
        });
        Progress {
            bar,
            counter,
            done: Some(done),
            timer: Some(timer),
        }
    }

    /// The counter the marcher stores its triangle count into.
    pub fn counter(&self) -> &AtomicU64 {
        &self.counter
    }

    /// Removes the progress bar (if it appeared) and stops its timer.
    pub fn finish(mut self) {
        self.stop();
    }

    fn stop(&mut self) {
        if let Some(done) = self.done.take() {
            // The timer may have stopped already; then nobody listens, which is fine.
            let _ = done.send(());
        }
        if let Some(timer) = self.timer.take() {
            let _ = timer.join();
        }
        self.bar.finish_and_clear();
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.stop();
    }
}

/// A rough number of triangles for a mesh bounded by a box: triangles of edge `step` over
/// half the box's surface area (about the area of a graph-like surface across the box). Only
/// a guide for the progress bar; None for an empty or non-finite box.
pub fn estimate_triangles(step: f64, lo: DVec3, hi: DVec3) -> Option<u64> {
    let d = hi - lo;
    let area = d.x * d.y + d.y * d.z + d.z * d.x;
    let triangle = 3f64.sqrt() / 4.0 * step * step;
    let estimate = area / triangle;
    (estimate.is_finite() && estimate >= 1.0).then(|| estimate.min(u64::MAX as f64) as u64)
}

/// The `--stats` table: one line per mesh after a header line, columns aligned: the
/// percentiles of the triangles' smallest angles, the radius ratios, the edge lengths.
pub fn format_stats(rows: &[(&str, &MeshReport)]) -> String {
    let header = [
        "mesh",
        "min°",
        "p1°",
        "p5°",
        "median°",
        "ratio mean",
        "ratio min",
        "edge min",
        "edge mean",
        "edge max",
    ]
    .map(String::from);
    let lines: Vec<[String; 10]> = rows
        .iter()
        .map(|(name, r)| {
            let s = &r.stats;
            let angle = |x: f64| format!("{x:.1}");
            let number = |x: f64| format!("{x:.4}");
            [
                (*name).to_owned(),
                angle(r.min_angle_deg),
                angle(s.min_angle_p1_deg),
                angle(s.min_angle_p5_deg),
                angle(s.min_angle_median_deg),
                number(s.radius_ratio_mean),
                number(s.radius_ratio_min),
                number(s.edge_min),
                number(s.edge_mean),
                number(s.edge_max),
            ]
        })
        .collect();
    aligned(&header, &lines, &[0])
}

/// Rows of cells as text, columns two spaces apart, each line ending in a newline: the
/// columns listed in `left` aligned to the left (the last one unpadded), the others to the
/// right.
fn aligned<const N: usize>(header: &[String; N], lines: &[[String; N]], left: &[usize]) -> String {
    let mut widths = [0usize; N];
    for line in std::iter::once(header).chain(lines) {
        for (w, cell) in widths.iter_mut().zip(line) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let mut out = String::new();
    for line in std::iter::once(header).chain(lines) {
        for (k, cell) in line.iter().enumerate() {
            let pad = " ".repeat(widths[k] - cell.chars().count());
            if k > 0 {
                out.push_str("  ");
            }
            if !left.contains(&k) {
                out.push_str(&pad);
            }
            out.push_str(cell);
            if left.contains(&k) && k + 1 < N {
                out.push_str(&pad);
            }
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_aligns_its_columns() {
        let rows = [
            MeshSummary {
                name: "sphere",
                triangles: 1544,
                components: 1,
                seconds: 0.0123,
                boundary_loops: 0,
                non_manifold_edges: 0,
            },
            MeshSummary {
                name: "sphere_six_holes",
                triangles: 2206,
                components: 1,
                seconds: 1.5,
                boundary_loops: 6,
                non_manifold_edges: 0,
            },
            MeshSummary {
                name: "cap",
                triangles: 12,
                components: 2,
                seconds: 0.0004,
                boundary_loops: 1,
                non_manifold_edges: 2,
            },
        ];
        let expected = "\
mesh              triangles  components    time  topology
sphere                 1544           1   12 ms  watertight
sphere_six_holes       2206           1  1.50 s  6 boundary loops
cap                      12           2    0 ms  1 boundary loop, 2 non-manifold edges
";
        assert_eq!(format_summary(&rows), expected);
    }

    #[test]
    fn the_estimate_covers_half_the_box_surface() {
        // A 2 × 2 × 1 box: half its surface is 4 + 2 + 2 = 8; a triangle of edge 0.1 has
        // the area √3/4 · 0.01.
        let estimate = estimate_triangles(0.1, DVec3::new(-1.0, -1.0, 0.0), DVec3::ONE);
        let expected = 8.0 / (3f64.sqrt() / 4.0 * 0.01);
        assert_eq!(estimate, Some(expected as u64));
        assert_eq!(estimate_triangles(0.1, DVec3::ONE, DVec3::ONE), None);
        assert_eq!(estimate_triangles(f64::NAN, DVec3::ZERO, DVec3::ONE), None);
    }

    #[test]
    fn a_quiet_or_piped_spinner_never_draws() {
        // Quiet: no timer at all. Otherwise (terminal or not) nothing shows in the first half
        // second, and finishing early stops the timer before it fires.
        for quiet in [true, false] {
            let progress = Progress::start("m", quiet, Some(100));
            assert!(progress.bar.is_hidden());
            progress.counter().store(10, Ordering::Relaxed);
            if quiet {
                assert!(progress.timer.is_none());
            }
            progress.finish();
        }
    }
}
