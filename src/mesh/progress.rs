//! Progress while a long run goes, as counts and as what a person sees on stderr. The counts
//! ([`Counts`]: the triangles of a mesh block's marches so far and the components its search
//! has found; the bytes a writer has written) are atomics that the workers add to in
//! batches — one atomic add per batch of triangles ([`Tally`]) or per 64 KiB, never one per
//! triangle — and that a timer thread reads. The bars ([`Bars`]) show them: one line per
//! mesh block being meshed, and one while the file is written, all lines of a run drawn
//! together so that blocks meshed at once do not overwrite each other. The counts are only
//! ever read for display: nothing computed depends on them.

use std::cell::Cell;
use std::io::IsTerminal;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::thread::JoinHandle;
use std::time::Duration;

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

/// What one mesh block has made so far.
#[derive(Debug, Default)]
pub struct Counts {
    /// Triangles of the block's marches: those finished and kept, and those under way.
    pub triangles: AtomicU64,
    /// Components the block's component search has found (0 where it has none).
    pub components: AtomicU64,
}

impl Counts {
    pub fn new() -> Counts {
        Counts::default()
    }
}

/// Reads a count that marches add to and take back from. A take-back never passes what was
/// added, so the count stays a sum of non-negative shares; should a share ever be taken back
/// twice, the wrapped value reads as 0 rather than as a number near 2⁶⁴.
fn read(count: &AtomicU64) -> u64 {
    let n = count.load(Ordering::Relaxed);
    if n > u64::MAX / 2 { 0 } else { n }
}

/// Triangles a march makes between two adds to the shared count.
pub const TALLY_BATCH: u64 = 1024;

/// One march's share of a block's triangle count: what it has added to the shared count, so
/// that a march made again (the verification's refinements) or one whose mesh is thrown away
/// takes its triangles back. Adds in batches of [`TALLY_BATCH`] triangles. Used through a
/// shared reference by the one thread that marches (the share is a `Cell`).
#[derive(Debug)]
pub struct Tally<'a> {
    counter: Option<&'a AtomicU64>,
    added: Cell<u64>,
}

impl<'a> Tally<'a> {
    pub fn new(counter: Option<&'a AtomicU64>) -> Tally<'a> {
        Tally {
            counter,
            added: Cell::new(0),
        }
    }

    /// The march has `n` triangles now: the share follows when it is a batch or more away
    /// (either way: a march made again starts from none).
    #[inline]
    pub fn at(&self, n: u64) {
        if self.counter.is_some() && n.abs_diff(self.added.get()) >= TALLY_BATCH {
            self.set(n);
        }
    }

    /// The share becomes exactly `n` (a march's final count).
    pub fn set(&self, n: u64) {
        let added = self.added.get();
        if let Some(counter) = self.counter {
            if n >= added {
                counter.fetch_add(n - added, Ordering::Relaxed);
            } else {
                counter.fetch_sub(added - n, Ordering::Relaxed);
            }
        }
        self.added.set(n);
    }

    /// Takes back all the share (a march that failed).
    pub fn retract(&self) {
        self.set(0);
    }
}

/// How long a line waits before it appears: quick work shows nothing.
const DELAY: Duration = Duration::from_millis(500);

/// [`DELAY`], or the milliseconds in `SURFC_PROGRESS_DELAY_MS`: the progress test shows the
/// lines at once, so that what it reads does not depend on how fast the machine meshes.
fn delay() -> Duration {
    std::env::var("SURFC_PROGRESS_DELAY_MS")
        .ok()
        .and_then(|ms| ms.parse().ok())
        .map_or(DELAY, Duration::from_millis)
}
/// How often a visible line redraws.
const TICK: Duration = Duration::from_millis(100);

/// A mesh block's line while its count is below the estimate.
const ESTIMATED: &str = "{spinner} meshing {prefix}: {pos} of ~{len} triangles{msg} [{bar:30}] ({elapsed}, about {eta} left)";
/// A mesh block's line without an estimate, or past it.
const COUNTING: &str = "{spinner} meshing {prefix}: {pos} triangles{msg} ({elapsed})";
/// The line of a file being written.
const WRITING: &str = "{spinner} writing {prefix}: {bytes} ({binary_bytes_per_sec}, {elapsed})";

fn set_style(bar: &ProgressBar, template: &str) {
    if let Ok(style) = ProgressStyle::with_template(template) {
        bar.set_style(style.progress_chars("=> "));
    }
}

/// The progress lines of one command on stderr: they appear only when stderr is a terminal
/// and the command is not quiet, each only once its work has taken half a second, and they
/// vanish when it is done. Lines of work done at once (mesh blocks on several threads) are
/// drawn together, one below the other.
#[derive(Clone)]
pub struct Bars {
    /// None when nothing is ever shown.
    multi: Option<MultiProgress>,
}

impl Bars {
    /// Lines on stderr, unless `quiet` or stderr is not a terminal.
    pub fn new(quiet: bool) -> Bars {
        Bars::to(!quiet && std::io::stderr().is_terminal())
    }

    /// Lines on stderr if `shown`, else none at all (no timer threads either).
    pub fn to(shown: bool) -> Bars {
        Bars {
            multi: shown.then(|| MultiProgress::with_draw_target(ProgressDrawTarget::stderr())),
        }
    }

    /// A line for the mesh block `name`, expected to have about `estimate` triangles: the
    /// triangles made so far (and the components found, once there are any), with a bar and
    /// the time left towards the estimate while the count is below it.
    pub fn block(&self, name: &str, estimate: Option<u64>) -> Line<Counts> {
        self.line(
            name,
            estimate,
            Arc::new(Counts::new()),
            |bar, counts| {
                let made = read(&counts.triangles);
                // An estimate is only that: past it, the line shows the count alone.
                if bar.length().is_some_and(|len| made > len) {
                    bar.unset_length();
                    set_style(bar, COUNTING);
                }
                bar.set_message(match read(&counts.components) {
                    0 => String::new(),
                    1 => ", 1 component".to_owned(),
                    n => format!(", {n} components"),
                });
                bar.set_position(made);
            },
            |bar, length| {
                set_style(
                    bar,
                    if length.is_some() {
                        ESTIMATED
                    } else {
                        COUNTING
                    },
                )
            },
        )
    }

    /// A line for the file `name` being written: the bytes written so far and the rate.
    pub fn writing(&self, name: &str) -> Line<AtomicU64> {
        self.line(
            name,
            None,
            Arc::new(AtomicU64::new(0)),
            |bar, written| bar.set_position(read(written)),
            |bar, _| set_style(bar, WRITING),
        )
    }

    /// A line named `name` over `count`, which `update` shows on the bar at every tick.
    fn line<C: Send + Sync + 'static>(
        &self,
        name: &str,
        length: Option<u64>,
        count: Arc<C>,
        update: impl Fn(&ProgressBar, &C) + Send + 'static,
        style: impl FnOnce(&ProgressBar, Option<u64>),
    ) -> Line<C> {
        let bar = ProgressBar::with_draw_target(length, ProgressDrawTarget::hidden());
        style(&bar, length);
        bar.set_prefix(name.to_owned());
        let Some(multi) = self.multi.clone() else {
            return Line {
                count,
                bar,
                multi: None,
                done: None,
                timer: None,
            };
        };
        let (done, wait) = mpsc::channel::<()>();
        let (shown, watched) = (bar.clone(), Arc::clone(&count));
        let board = multi.clone();
        let timer = std::thread::spawn(move || {
            if wait.recv_timeout(delay()) != Err(RecvTimeoutError::Timeout) {
                return;
            }
            // The clock counts from the start of the work (the bar's creation), not from when
            // the line appears.
            let shown = board.add(shown);
            loop {
                update(&shown, &watched);
                shown.tick();
                if wait.recv_timeout(TICK) != Err(RecvTimeoutError::Timeout) {
                    return;
                }
            }
        });
        Line {
            count,
            bar,
            multi: Some(multi),
            done: Some(done),
            timer: Some(timer),
        }
    }
}

/// One progress line: the count it shows, which the work adds to; it vanishes when finished
/// or dropped.
pub struct Line<C> {
    count: Arc<C>,
    bar: ProgressBar,
    multi: Option<MultiProgress>,
    /// Tells the timer thread that the work is done.
    done: Option<mpsc::Sender<()>>,
    timer: Option<JoinHandle<()>>,
}

impl<C> Line<C> {
    /// The count the work adds to.
    pub fn count(&self) -> &C {
        &self.count
    }

    /// Removes the line (if it appeared) and stops its timer.
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
        if let Some(multi) = self.multi.take() {
            multi.remove(&self.bar);
        }
    }
}

impl<C> Drop for Line<C> {
    fn drop(&mut self) {
        self.stop();
    }
}

/// A rough number of triangles for a mesh bounded by a box: triangles of edge `step` over
/// half the box's surface area (about the area of a graph-like surface across the box). Only
/// a guide for the progress bar; None for an empty or non-finite box.
pub fn estimate_triangles(step: f64, lo: glam::DVec3, hi: glam::DVec3) -> Option<u64> {
    let d = hi - lo;
    let area = d.x * d.y + d.y * d.z + d.z * d.x;
    let triangle = 3f64.sqrt() / 4.0 * step * step;
    let estimate = area / triangle;
    (estimate.is_finite() && estimate >= 1.0).then(|| estimate.min(u64::MAX as f64) as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_estimate_covers_half_the_box_surface() {
        use glam::DVec3;
        // A 2 × 2 × 1 box: half its surface is 4 + 2 + 2 = 8; a triangle of edge 0.1 has
        // the area √3/4 · 0.01.
        let estimate = estimate_triangles(0.1, DVec3::new(-1.0, -1.0, 0.0), DVec3::ONE);
        let expected = 8.0 / (3f64.sqrt() / 4.0 * 0.01);
        assert_eq!(estimate, Some(expected as u64));
        assert_eq!(estimate_triangles(0.1, DVec3::ONE, DVec3::ONE), None);
        assert_eq!(estimate_triangles(f64::NAN, DVec3::ZERO, DVec3::ONE), None);
    }

    #[test]
    fn hidden_lines_start_no_timer() {
        let bars = Bars::to(false);
        let line = bars.block("m", Some(100));
        line.count().triangles.fetch_add(10, Ordering::Relaxed);
        assert!(line.timer.is_none());
        assert!(line.bar.is_hidden());
        line.finish();
    }

    #[test]
    fn a_tally_adds_in_batches_and_takes_back_what_it_added() {
        let shared = AtomicU64::new(7);
        let a = Tally::new(Some(&shared));
        let b = Tally::new(Some(&shared));
        for n in 0..TALLY_BATCH {
            a.at(n);
        }
        // Below a batch: nothing added yet.
        assert_eq!(shared.load(Ordering::Relaxed), 7);
        a.at(TALLY_BATCH);
        b.set(5);
        assert_eq!(shared.load(Ordering::Relaxed), 7 + TALLY_BATCH + 5);
        // A march made again starts from none: its share follows it down.
        a.at(0);
        assert_eq!(shared.load(Ordering::Relaxed), 7 + 5);
        a.set(3);
        b.retract();
        assert_eq!(shared.load(Ordering::Relaxed), 7 + 3);
        // Without a counter, nothing happens.
        let none = Tally::new(None);
        none.set(100);
        none.retract();
    }
}
