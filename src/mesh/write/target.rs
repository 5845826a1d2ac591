//! Where the bytes of an output path go, decided before anything is written: a regular file
//! (new or existing) is replaced atomically next to itself; a symlink is followed to its final
//! target, which is then replaced (the link stays a link); a FIFO or a device is written in
//! place (a temporary file and a rename would replace it by a regular file). Refused: the
//! input file itself (by device and inode, not by name), a read-only file, a directory.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use super::WriteError;

/// How many symlinks are followed before giving up (Linux's own limit).
const MAX_LINKS: usize = 40;

/// Where and how an output path is written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Target {
    /// A regular file, existing or not: a temporary file beside it, then a rename onto it.
    Replace(PathBuf),
    /// A FIFO, a character or block device, or a socket: opened and written in place.
    Direct(PathBuf),
}

/// Resolves `path` to what [`write_atomic`](super::write_atomic) writes. Errors name `path`
/// as the user gave it (and the resolved file when a link led there).
pub fn resolve(path: &Path) -> Result<Target, WriteError> {
    let mut current = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        let meta = match fs::symlink_metadata(&current) {
            Ok(m) => m,
            // A new file (possibly the missing target of a dangling link), or one under a
            // missing directory, which the writer reports as such.
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::NotFound | io::ErrorKind::NotADirectory
                ) =>
            {
                return Ok(Target::Replace(current));
            }
            Err(source) => {
                return Err(WriteError::Write {
                    path: path.to_path_buf(),
                    source,
                });
            }
        };
        let kind = meta.file_type();
        if kind.is_symlink() {
            let link = fs::read_link(&current).map_err(|source| WriteError::Write {
                path: path.to_path_buf(),
                source,
            })?;
            current = match current.parent() {
                Some(dir) if link.is_relative() => dir.join(link),
                _ => link,
            };
            continue;
        }
        if kind.is_dir() {
            return Err(WriteError::IsDirectory {
                path: path.to_path_buf(),
            });
        }
        if is_special(&kind) {
            return Ok(Target::Direct(current));
        }
        // Permission bits, not access(2): root may write anything, but a file its owner made
        // read-only is one the user meant to keep.
        if meta.permissions().readonly() {
            return Err(WriteError::ReadOnly {
                path: path.to_path_buf(),
                file: current,
            });
        }
        return Ok(Target::Replace(current));
    }
    Err(WriteError::Write {
        path: path.to_path_buf(),
        source: io::Error::other(format!("more than {MAX_LINKS} levels of symbolic links")),
    })
}

/// Checks before any work is done that `output` can be written as [`resolve`] says, and that
/// it is not the same file as `input` (followed through links, compared by device and
/// inode), so that `surfc mesh a.surf -o a.surf` cannot overwrite the source. An output that
/// does not exist yet, or an input that cannot be read, is no conflict.
pub fn check_output(output: &Path, input: &Path) -> Result<(), WriteError> {
    match (fs::metadata(output), fs::metadata(input)) {
        (Ok(o), Ok(i)) if same_file(&o, &i) => Err(WriteError::SameAsInput {
            path: output.to_path_buf(),
            input: input.to_path_buf(),
        }),
        _ => resolve(output).map(|_| ()),
    }
}

#[cfg(unix)]
fn same_file(a: &fs::Metadata, b: &fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    a.dev() == b.dev() && a.ino() == b.ino()
}

#[cfg(not(unix))]
fn same_file(_: &fs::Metadata, _: &fs::Metadata) -> bool {
    // Without inodes the check is left to the file system (a file open for reading cannot
    // be replaced on Windows).
    false
}

#[cfg(unix)]
fn is_special(kind: &fs::FileType) -> bool {
    use std::os::unix::fs::FileTypeExt;
    kind.is_fifo() || kind.is_char_device() || kind.is_block_device() || kind.is_socket()
}

#[cfg(not(unix))]
fn is_special(_: &fs::FileType) -> bool {
    false
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    /// A fresh directory for one test, removed when it ends.
    fn scratch() -> tempfile::TempDir {
        tempfile::tempdir().expect("a temporary directory")
    }

    #[test]
    fn links_are_followed_to_their_final_target() {
        let scratch = scratch();
        let dir = scratch.path();
        let file = dir.join("real.obj");
        std::os::unix::fs::symlink("real.obj", dir.join("one")).unwrap();
        std::os::unix::fs::symlink(dir.join("one"), dir.join("two")).unwrap();
        // A dangling chain ends at the file it would create.
        assert_eq!(
            resolve(&dir.join("two")).unwrap(),
            Target::Replace(file.clone())
        );
        fs::write(&file, "old").unwrap();
        assert_eq!(resolve(&dir.join("two")).unwrap(), Target::Replace(file));
        std::os::unix::fs::symlink("loop", dir.join("loop")).unwrap();
        assert!(resolve(&dir.join("loop")).is_err());
    }

    #[test]
    fn devices_are_direct_and_directories_refused() {
        assert_eq!(
            resolve(Path::new("/dev/null")).unwrap(),
            Target::Direct("/dev/null".into())
        );
        let scratch = scratch();
        let dir = scratch.path();
        assert!(matches!(resolve(dir), Err(WriteError::IsDirectory { .. })));
    }
}
