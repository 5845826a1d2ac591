//! The one switch of the step-by-step trace: `SURFC_TRACE` set to anything but empty or `0`
//! makes the marcher, the quality stage, the local step and the pipeline's drivers print
//! what they do to stderr (to re-run a failing mesh and see where it went wrong). Imports
//! nothing of the crate; every stage may ask it.

/// Whether `SURFC_TRACE` asks for a trace (read each time: a test or an embedder may set it
/// between meshes).
pub fn enabled() -> bool {
    std::env::var_os("SURFC_TRACE").is_some_and(|v| !v.is_empty() && v != "0")
}
