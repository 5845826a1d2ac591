//! Interruption: on SIGINT (Ctrl-C), SIGTERM or SIGHUP the temporary files of the writes under
//! way are removed (`mesh::write::remove_temporary_files`), so that an interrupted `mesh`,
//! `render` or `fmt --write` leaves its output as it was and no `.NAME.*.tmp` behind, and the
//! process exits with 128 + the signal's number (130 for Ctrl-C, as shells report it). The
//! handler runs on a thread of its own (signal-hook's iterator), not in the signal's
//! context, so it may take locks and remove files. `surfc watch`, which runs until Ctrl-C,
//! says so ([`watching`]): there SIGINT is the way to stop, which removes the same files and
//! exits 0 with `stopped watching`.

use std::sync::atomic::{AtomicBool, Ordering};

/// Whether SIGINT ends a `surfc watch` (exit 0) rather than interrupts a command (exit 130).
static WATCHING: AtomicBool = AtomicBool::new(false);

/// From now on SIGINT stops a watch: the temporary files of the writes under way are removed
/// as for any interruption, then the process says `stopped watching` and exits 0.
pub(crate) fn watching() {
    WATCHING.store(true, Ordering::SeqCst);
}

/// Starts the thread that waits for the signals. A failure to install the handlers (which
/// leaves the signals' default actions: the process ends, a temporary file may stay) is
/// reported on stderr and is not fatal.
#[cfg(unix)]
pub(crate) fn install() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    use signal_hook::iterator::Signals;

    let mut signals = match Signals::new([SIGINT, SIGTERM, SIGHUP]) {
        Ok(signals) => signals,
        Err(e) => {
            eprintln!(
                "warning: cannot handle interruptions ({e}): an interrupted write may leave a temporary file"
            );
            return;
        }
    };
    let spawned = std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            if let Some(signal) = signals.forever().next() {
                // Held until the process ends: no write begins a temporary file meanwhile.
                let _held = crate::mesh::write::remove_temporary_files();
                // A progress line may be half drawn: the message starts on a line of its own.
                if signal == SIGINT && WATCHING.load(Ordering::SeqCst) {
                    eprintln!("\nstopped watching");
                    std::process::exit(0);
                }
                eprintln!("\ninterrupted");
                std::process::exit(128 + signal);
            }
        });
    if let Err(e) = spawned {
        eprintln!(
            "warning: cannot handle interruptions ({e}): an interrupted write may leave a temporary file"
        );
    }
}

#[cfg(not(unix))]
pub(crate) fn install() {}
