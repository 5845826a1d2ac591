//! `surfc watch FILE [mesh options] [--render OUT.png]`: the edit–see loop. Meshes FILE as
//! `surfc mesh` does, then again whenever FILE or a file it imports is saved, until Ctrl-C.
//! It owns the waiting: the operating system's file events (the `notify` crate: inotify,
//! FSEvents, ReadDirectoryChanges; no polling) on the directories of the input files,
//! filtered to those files and debounced, and the set of files, which follows the imports
//! of the last build. Each rebuild writes the mesh file (and the picture of `--render`)
//! atomically and prints one line; a broken save prints its diagnostics and leaves the last
//! good files in place. SIGINT ends it with exit 0 (`signals::watching`).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use notify::{EventKind, RecursiveMode, Watcher};

use super::load::{ReadFile, is_stdin, load_with_imports};
use super::mesh::{MeshArgs, Output, choose_output, mesh_and_write, print_json, print_stats};
use super::report::Failure;
use super::{ColorMode, EXIT_USAGE};
use crate::mesh::render::write_picture_file;
use crate::mesh::render::{PictureFormat, RenderOptions, parse_size, parse_view};
use crate::mesh::write::{Format, target};
use crate::pipeline::{Meshed, named};

/// How long the inputs must be quiet after a change before the rebuild starts: an editor's
/// save is several events (write a temporary file, rename it, change its mode) within a few
/// milliseconds, and a `git checkout` of several files as many; 100 ms takes them as one.
pub const QUIET: Duration = Duration::from_millis(100);

/// The longest a rebuild waits for the inputs to be quiet, counted from the first change: a
/// file rewritten without pause (a long copy) is built as it is then.
pub const QUIET_AT_MOST: Duration = Duration::from_secs(1);

#[derive(clap::Args, Debug)]
pub struct WatchArgs {
    /// Every option of `surfc mesh`; FILE and OUT must be files (not `-`).
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Also draw the meshes into this picture (.png or .svg) at every rebuild.
    #[arg(long, value_name = "OUT.png")]
    pub render: Option<PathBuf>,
    /// Picture size in pixels, WxH (with `--render`).
    #[arg(long, default_value = "800x600", requires = "render")]
    pub size: String,
    /// View direction of the picture: azimuth and elevation in degrees, AZ,EL (with
    /// `--render`).
    #[arg(
        long,
        default_value = "30,25",
        allow_hyphen_values = true,
        requires = "render"
    )]
    pub view: String,
}

/// What a rebuild writes, settled before the first one.
struct Plan {
    output: PathBuf,
    format: Format,
    picture: Option<(PathBuf, RenderOptions)>,
}

pub fn run(args: WatchArgs, color: ColorMode) -> u8 {
    let plan = match plan(&args) {
        Ok(plan) => plan,
        Err(failure) => return failure.finish(args.mesh.json),
    };
    // A file that is not there at the start is a mistyped name more likely than one to come.
    if let Err(e) = std::fs::metadata(&args.mesh.file) {
        let file = &args.mesh.file;
        return Failure::io(format!("cannot read `{}`: {e}", file.display()), file)
            .finish(args.mesh.json);
    }
    let pool = match rayon::ThreadPoolBuilder::new()
        .num_threads(args.mesh.threads.map_or(0, usize::from))
        .build()
    {
        Ok(pool) => pool,
        Err(e) => {
            return Failure::usage(format!("cannot start the threads: {e}")).finish(args.mesh.json);
        }
    };
    let (sender, events) = std::sync::mpsc::channel();
    let watcher = match notify::recommended_watcher(sender) {
        Ok(watcher) => watcher,
        Err(e) => {
            return Failure::new(
                EXIT_USAGE,
                super::report::CODE_IO,
                format!("cannot watch files: {e}"),
                None,
            )
            .finish(args.mesh.json);
        }
    };
    super::signals::watching();
    let mut inputs = Inputs::new(watcher);
    // Watched before the first build, so that a save while it runs is seen.
    inputs.follow(std::slice::from_ref(&args.mesh.file));
    if !args.mesh.quiet {
        eprintln!(
            "watching `{}` and the files it imports: a rebuild at every save, Ctrl-C stops",
            args.mesh.file.display()
        );
    }
    let mut state = State::default();
    loop {
        let read = pool.install(|| rebuild(&args, &plan, color, &mut state));
        let paths: Vec<PathBuf> = read.iter().map(|(path, _)| path.clone()).collect();
        inputs.follow(&paths);
        // A file may have changed since the build read it, before its directory was watched
        // (an import new in this build): then its event never comes, and it is built now.
        // Else the next change is waited for; an event that changed nothing (a save of the
        // same text, `touch`) is no rebuild.
        loop {
            if !changed(&read) && !inputs.next_change(&events) {
                // The watcher is gone: nothing more can come.
                eprintln!("error: the file watcher stopped");
                return EXIT_USAGE;
            }
            inputs.settle(&events);
            if changed(&read) {
                break;
            }
        }
    }
}

/// Whether any input file now holds other bytes than the build read (or is there where it
/// was not, or the reverse).
fn changed(read: &[ReadFile]) -> bool {
    read.iter()
        .any(|(path, bytes)| std::fs::read(path).ok() != *bytes)
}

/// The outputs, from the mesh options and `--render`; a usage error where `surfc mesh` or
/// `surfc render` would refuse them, or where there is nothing to watch.
fn plan(args: &WatchArgs) -> Result<Plan, Failure> {
    if is_stdin(&args.mesh.file) {
        return Err(Failure::usage(
            "`surfc watch` watches a file; standard input (`-`) cannot be saved again".into(),
        ));
    }
    let (output, format) = match choose_output(&args.mesh)? {
        (Output::File(path), format) => (path, format),
        (Output::Stdout, _) => {
            return Err(Failure::usage(
                "`surfc watch` writes a file at every rebuild; `-o -` (standard output) is for `surfc mesh`".into(),
            ));
        }
    };
    target::check_output(&output, &args.mesh.file)
        .map_err(|e| Failure::io(e.to_string(), &output))?;
    let picture = match &args.render {
        None => None,
        Some(path) => {
            PictureFormat::from_path(path).map_err(|e| Failure::usage(e.to_string()))?;
            target::check_output(path, &args.mesh.file)
                .map_err(|e| Failure::io(e.to_string(), path))?;
            let (width, height) = parse_size(&args.size)
                .map_err(|e| Failure::usage(format!("--size {}: {e}", args.size)))?;
            let view = parse_view(&args.view)
                .map_err(|e| Failure::usage(format!("--view {}: {e}", args.view)))?;
            let options = RenderOptions {
                width,
                height,
                view,
                ..RenderOptions::default()
            };
            Some((path.clone(), options))
        }
    };
    Ok(Plan {
        output,
        format,
        picture,
    })
}

/// What the rebuilds remember.
#[derive(Default)]
struct State {
    /// Rebuilds that wrote their files.
    good: usize,
}

/// Loads, meshes, writes and draws once, printing what happened; the files the build read or
/// wanted (FILE and every file it imports) with what it read of them, to watch until the
/// next.
fn rebuild(args: &WatchArgs, plan: &Plan, color: ColorMode, state: &mut State) -> Vec<ReadFile> {
    let started = Instant::now();
    let (loaded, files) = load_with_imports(&args.mesh.file, color, &args.mesh.defines);
    let built = loaded.and_then(|loaded| {
        let output = Output::File(plan.output.clone());
        let (meshed, _) = mesh_and_write(&loaded, &args.mesh, &output, plan.format, color)?;
        if let Some((path, options)) = &plan.picture {
            write_picture_file(path, &named(&meshed), options)
                .map_err(|e| Failure::io(e.to_string(), path))?;
        }
        Ok(meshed)
    });
    match built {
        Ok(meshed) => {
            state.good += 1;
            // stdout that cannot take the report was said on stderr; the watch goes on.
            if args.mesh.json {
                let _ = print_json(&meshed, started);
            }
            if args.mesh.stats {
                print_stats(&meshed);
            }
            eprintln!("{}", rebuilt_line(plan, &meshed, started.elapsed()));
        }
        Err(failure) => {
            let _ = failure.finish(args.mesh.json);
            let kept = if state.good > 0 {
                "the files of the last good build are left in place"
            } else {
                "nothing written"
            };
            eprintln!(
                "failed in {}: {kept}; waiting for the next save",
                seconds(started.elapsed())
            );
        }
    }
    files
}

/// The one line of a rebuild that wrote its files: what it wrote, how long it took, and the
/// meshes in sum.
fn rebuilt_line(plan: &Plan, meshed: &[Meshed], took: Duration) -> String {
    let mut written = plan.output.display().to_string();
    if let Some((picture, _)) = &plan.picture {
        written = format!("{written} and {}", picture.display());
    }
    let plural = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    let meshes = match meshed.len() {
        1 => "1 mesh".to_owned(),
        n => format!("{n} meshes"),
    };
    let triangles: usize = meshed.iter().map(|m| m.report.triangles).sum();
    let loops: usize = meshed.iter().map(|m| m.report.boundary_loops).sum();
    let bad: usize = meshed.iter().map(|m| m.report.non_manifold_edges).sum();
    let topology = match (loops, bad) {
        (0, 0) => "watertight".to_owned(),
        (loops, 0) => plural(loops, "boundary loop"),
        (loops, bad) => format!(
            "{}, {}",
            plural(loops, "boundary loop"),
            plural(bad, "non-manifold edge")
        ),
    };
    format!(
        "rebuilt {written} in {}: {meshes}, {}, {topology}",
        seconds(took),
        plural(triangles, "triangle")
    )
}

fn seconds(d: Duration) -> String {
    format!("{:.2} s", d.as_secs_f64())
}

/// The input files and the watches on their directories. A directory is watched, not the
/// file: an editor that saves by writing a new file and renaming it over the old one (vim,
/// most IDEs) replaces the file a watch on it would follow, and a file imported but not yet
/// there can only be seen appearing in its directory.
struct Inputs<W: Watcher> {
    watcher: W,
    /// The files, each as its canonical directory joined with its name (how events name
    /// them), and for a symlink its target's too.
    files: BTreeSet<PathBuf>,
    /// The directories watched.
    dirs: BTreeSet<PathBuf>,
}

impl<W: Watcher> Inputs<W> {
    fn new(watcher: W) -> Inputs<W> {
        Inputs {
            watcher,
            files: BTreeSet::new(),
            dirs: BTreeSet::new(),
        }
    }

    /// Watches `paths` (and no longer what is not among them).
    fn follow(&mut self, paths: &[PathBuf]) {
        let mut files = BTreeSet::new();
        for path in paths {
            files.extend(event_names(path));
        }
        let dirs: BTreeSet<PathBuf> = files
            .iter()
            .filter_map(|f| f.parent().map(Path::to_path_buf))
            .collect();
        for gone in self.dirs.difference(&dirs) {
            // A directory removed since is no longer watched anyway.
            let _ = self.watcher.unwatch(gone);
        }
        for new in dirs.difference(&self.dirs) {
            if let Err(e) = self.watcher.watch(new, RecursiveMode::NonRecursive) {
                eprintln!("warning: cannot watch `{}`: {e}", new.display());
            }
        }
        self.files = files;
        self.dirs = dirs;
    }

    /// Waits for an event that may change an input file. False if the watcher has gone.
    fn next_change(&self, events: &Receiver<notify::Result<notify::Event>>) -> bool {
        loop {
            match events.recv() {
                Ok(event) if self.concerns(&event) => return true,
                Ok(_) => {}
                Err(_) => return false,
            }
        }
    }

    /// Waits for the inputs to be quiet: no event that concerns them for [`QUIET`], and at
    /// most [`QUIET_AT_MOST`].
    fn settle(&self, events: &Receiver<notify::Result<notify::Event>>) {
        let first = Instant::now();
        let mut quiet_from = first;
        loop {
            let deadline = (quiet_from + QUIET).min(first + QUIET_AT_MOST);
            let Some(left) = deadline.checked_duration_since(Instant::now()) else {
                return;
            };
            match events.recv_timeout(left) {
                Ok(event) if self.concerns(&event) => quiet_from = Instant::now(),
                Ok(_) => {}
                // A watcher gone is seen by the next `next_change`.
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => return,
            }
        }
    }

    /// Whether an event may change an input: its contents, its name, its being there. A
    /// read (surfc's own, an editor's) is none; an error of the watcher (events lost) may be.
    fn concerns(&self, event: &notify::Result<notify::Event>) -> bool {
        match event {
            Ok(event) => {
                let changes = matches!(
                    event.kind,
                    EventKind::Any
                        | EventKind::Create(_)
                        | EventKind::Modify(_)
                        | EventKind::Remove(_)
                        | EventKind::Other
                        | EventKind::Access(notify::event::AccessKind::Close(
                            notify::event::AccessMode::Write
                        ))
                );
                // An event without paths (a rescan) may concern any file.
                changes
                    && (event.paths.is_empty()
                        || event.paths.iter().any(|p| self.files.contains(p)))
            }
            Err(_) => true,
        }
    }
}

/// The names events give `path`: its canonical directory joined with its name, and, for a
/// symlink, its target's canonical path too. A path whose directory is missing has none.
fn event_names(path: &Path) -> Vec<PathBuf> {
    let mut names = Vec::new();
    let dir = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    };
    if let (Ok(dir), Some(name)) = (std::fs::canonicalize(dir), path.file_name()) {
        names.push(dir.join(name));
    }
    if let Ok(target) = std::fs::canonicalize(path)
        && !names.contains(&target)
    {
        names.push(target);
    }
    names
}
