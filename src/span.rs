//! Byte spans into one source file. Every AST node carries one; diagnostics point with them.

/// A half-open byte range `start..end` into the source text of one file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Span {
    pub start: u32,
    pub end: u32,
}

impl Span {
    pub fn new(start: usize, end: usize) -> Span {
        Span {
            start: start as u32,
            end: end as u32,
        }
    }

    /// The smallest span covering both.
    pub fn join(self, other: Span) -> Span {
        Span {
            start: self.start.min(other.start),
            end: self.end.max(other.end),
        }
    }

    pub fn range(self) -> std::ops::Range<usize> {
        self.start as usize..self.end as usize
    }
}

/// The files of one compilation laid end to end in one byte space, so that a `Span` names its
/// file by where it falls: the root file at offset 0, each imported file after the previous
/// one with a gap of one byte (an empty file still has an offset of its own).
#[derive(Clone, Debug, Default)]
pub struct SourceMap {
    files: Vec<SourceFile>,
}

/// One file of a [`SourceMap`].
#[derive(Clone, Debug)]
pub struct SourceFile {
    /// The name diagnostics show (the path as the user or the importing file wrote it).
    pub name: String,
    pub text: String,
    /// Where the file starts in the shared byte space.
    pub base: u32,
}

impl SourceMap {
    /// A map of one file at offset 0.
    pub fn single(name: &str, text: &str) -> SourceMap {
        let mut map = SourceMap::default();
        map.add(name, text);
        map
    }

    /// Adds a file after the others; its base offset, or None if the byte space is full.
    pub fn add(&mut self, name: &str, text: &str) -> Option<u32> {
        let base = match self.files.last() {
            Some(f) => f
                .base
                .checked_add(u32::try_from(f.text.len()).ok()?)?
                .checked_add(1)?,
            None => 0,
        };
        base.checked_add(u32::try_from(text.len()).ok()?)?;
        self.files.push(SourceFile {
            name: name.to_string(),
            text: text.to_string(),
            base,
        });
        Some(base)
    }

    /// The same files with the root file (the first) called `name`.
    pub fn with_root_name(&self, name: &str) -> SourceMap {
        let mut map = self.clone();
        if let Some(root) = map.files.first_mut() {
            root.name = name.to_string();
        }
        map
    }

    pub fn files(&self) -> &[SourceFile] {
        &self.files
    }

    /// The index of the file an offset falls in (the root file for an empty map's offsets).
    pub fn locate(&self, offset: u32) -> usize {
        self.files
            .partition_point(|f| f.base <= offset)
            .saturating_sub(1)
    }
}
