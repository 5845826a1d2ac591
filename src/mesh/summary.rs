//! What `surfc mesh` tells a person on stderr: a progress spinner while a slow mesh is being
//! made, and a short table afterwards (mesh, triangles, time, topology). Topology is computed
//! elsewhere; this module only formats the numbers it is given.

use std::io::IsTerminal;
use std::sync::mpsc::{self, RecvTimeoutError};
use std::thread::JoinHandle;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

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
    let mut widths = [0usize; 5];
    for line in std::iter::once(&header).chain(&lines) {
        for (w, cell) in widths.iter_mut().zip(line) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let mut out = String::new();
    for line in std::iter::once(&header).chain(&lines) {
        let pad = |k: usize| " ".repeat(widths[k] - line[k].chars().count());
        // Names and topology to the left, numbers to the right.
        out.push_str(&format!(
            "{}{}  {}{}  {}{}  {}{}  {}\n",
            line[0],
            pad(0),
            pad(1),
            line[1],
            pad(2),
            line[2],
            pad(3),
            line[3],
            line[4]
        ));
    }
    out
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

/// How long a mesh may take before its spinner appears.
const SPINNER_DELAY: Duration = Duration::from_millis(500);
/// How often a visible spinner redraws.
const SPINNER_TICK: Duration = Duration::from_millis(100);

/// A spinner for one mesh that appears only if the mesh takes longer than half a second, only
/// when stderr is a terminal, never when quiet; it vanishes when finished or dropped.
pub struct Progress {
    bar: ProgressBar,
    /// Tells the timer thread that the mesh is done.
    done: Option<mpsc::Sender<()>>,
    timer: Option<JoinHandle<()>>,
}

impl Progress {
    /// Starts timing the mesh called `name`.
    pub fn start(name: &str, quiet: bool) -> Progress {
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden());
        if let Ok(style) = ProgressStyle::with_template("{spinner} meshing {msg} ({elapsed})") {
            bar.set_style(style);
        }
        bar.set_message(name.to_owned());
        if quiet || !std::io::stderr().is_terminal() {
            return Progress {
                bar,
                done: None,
                timer: None,
            };
        }
        let (done, wait) = mpsc::channel::<()>();
        let shown = bar.clone();
        let timer = std::thread::spawn(move || {
            if let Err(RecvTimeoutError::Timeout) = wait.recv_timeout(SPINNER_DELAY) {
                shown.set_draw_target(ProgressDrawTarget::stderr());
                shown.enable_steady_tick(SPINNER_TICK);
            }
        });
        Progress {
            bar,
            done: Some(done),
            timer: Some(timer),
        }
    }

    /// Shows how far the mesh has come, e.g. its triangle count so far.
    pub fn set_message(&self, message: String) {
        self.bar.set_message(message);
    }

    /// Removes the spinner (if it appeared) and stops its timer.
    pub fn finish(mut self) {
        self.stop();
    }

    fn stop(&mut self) {
        if let Some(done) = self.done.take() {
            // The timer may have fired already; then nobody listens, which is fine.
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
    fn a_quiet_or_piped_spinner_never_draws() {
        // Quiet: no timer at all. Otherwise (terminal or not) nothing shows in the first half
        // second, and finishing early stops the timer before it fires.
        for quiet in [true, false] {
            let progress = Progress::start("m", quiet);
            assert!(progress.bar.is_hidden());
            progress.set_message("10 triangles".into());
            if quiet {
                assert!(progress.timer.is_none());
            }
            progress.finish();
        }
    }
}
