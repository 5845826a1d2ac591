//! `import "file";` → one AST of a root file and every file it imports (transitively, each
//! file once however often it is imported). The imported files' `const`, `fn`, `surface`,
//! `patch` and `curve` declarations come first, in the order the imports are reached, then
//! the root's items; imported mesh blocks are left out. Every span points into one
//! [`SourceMap`], so a diagnostic inside an imported file points into that file. A path is
//! relative to the directory of the file that imports it (the current directory for standard
//! input). A missing or unreadable file, a file that is not UTF-8, an import cycle (both
//! places shown) and imports nested too deep are diagnostics at the import.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use crate::diag::{Diagnostic, messages};
use crate::span::{SourceMap, Span};

use super::ast::{File, Item, ItemKind};

/// Imports nested deeper than this are a diagnostic (a chain of files importing each other
/// would otherwise only end with the stack).
pub const MAX_IMPORT_DEPTH: usize = 64;

/// The root file and its imports, parsed.
#[derive(Debug)]
pub struct Parsed {
    /// Every file read, the root first.
    pub map: SourceMap,
    /// The imported declarations and the root's items (no `import` items), if every file
    /// parsed and every import was found.
    pub file: Option<File>,
    /// Items whose span starts here or later come from imported files.
    pub imported_from: u32,
    pub diagnostics: Vec<Diagnostic>,
    /// Every file an `import` named, as the path joined to the importing file's directory,
    /// read or not (a missing one too): what a watcher of the source waits on besides the
    /// root.
    pub imports: Vec<PathBuf>,
}

/// One file on the path of imports being followed.
struct Open {
    path: PathBuf,
    /// The `import` that opened it (None for the root).
    import: Option<Span>,
}

struct Loader {
    map: SourceMap,
    diagnostics: Vec<Diagnostic>,
    stack: Vec<Open>,
    done: HashSet<PathBuf>,
    items: Vec<Item>,
    imports: Vec<PathBuf>,
}

/// Parses `root_text` (named `root_name`, in directory `root_dir`; `root_path` its path, if it
/// is a file, to find a cycle back to it) and everything it imports.
pub fn parse_with_imports(root_name: &str, root_path: Option<&Path>, root_text: &str) -> Parsed {
    let map = SourceMap::single(root_name, root_text);
    let imported_from = u32::try_from(root_text.len()).unwrap_or(u32::MAX);
    let (root, diagnostics) = super::parse(root_text);
    let mut loader = Loader {
        map,
        diagnostics,
        stack: Vec::new(),
        done: HashSet::new(),
        items: Vec::new(),
        imports: Vec::new(),
    };
    let Some(root) = root else {
        return loader.finish(None, imported_from);
    };
    let dir = root_path
        .and_then(Path::parent)
        .map_or_else(PathBuf::new, Path::to_path_buf);
    if let Some(p) = root_path.and_then(|p| std::fs::canonicalize(p).ok()) {
        loader.stack.push(Open {
            path: p,
            import: None,
        });
    }
    loader.imports(&root, &dir);
    let mut items = std::mem::take(&mut loader.items);
    items.extend(
        root.items
            .into_iter()
            .filter(|i| !matches!(i.kind, ItemKind::Import { .. })),
    );
    let file = File {
        items,
        comments: root.comments,
    };
    loader.finish(Some(file), imported_from)
}

impl Loader {
    fn finish(self, file: Option<File>, imported_from: u32) -> Parsed {
        let ok = !crate::diag::has_errors(&self.diagnostics);
        Parsed {
            map: self.map,
            file: file.filter(|_| ok),
            imported_from,
            diagnostics: self.diagnostics,
            imports: self.imports,
        }
    }

    /// Follows the imports of `file` (in directory `dir`).
    fn imports(&mut self, file: &File, dir: &Path) {
        for item in &file.items {
            if let ItemKind::Import { path } = &item.kind {
                self.import(&path.name, path.span, dir);
            }
        }
    }

    fn import(&mut self, written: &str, span: Span, dir: &Path) {
        let joined = dir.join(written);
        let shown = joined.display().to_string();
        if !self.imports.contains(&joined) {
            self.imports.push(joined.clone());
        }
        let canonical = match std::fs::canonicalize(&joined) {
            Ok(p) => p,
            Err(e) => {
                self.diagnostics
                    .push(messages::import_unreadable(span, written, &shown, &why(&e)));
                return;
            }
        };
        if let Some(k) = self.stack.iter().position(|o| o.path == canonical) {
            // The import in the cycle's first file that leads on to this one.
            let other = self.stack.get(k + 1).and_then(|o| o.import);
            self.diagnostics
                .push(messages::import_cycle(span, written, other));
            return;
        }
        if self.done.contains(&canonical) {
            return;
        }
        if self.stack.len() >= MAX_IMPORT_DEPTH {
            self.diagnostics
                .push(messages::imports_too_deep(span, MAX_IMPORT_DEPTH));
            return;
        }
        self.done.insert(canonical.clone());
        let text = match std::fs::read(&canonical) {
            Ok(bytes) => match String::from_utf8(bytes) {
                Ok(t) => t,
                Err(_) => {
                    self.diagnostics.push(messages::import_unreadable(
                        span,
                        written,
                        &shown,
                        "the file is not UTF-8 text",
                    ));
                    return;
                }
            },
            Err(e) => {
                self.diagnostics
                    .push(messages::import_unreadable(span, written, &shown, &why(&e)));
                return;
            }
        };
        let Some(base) = self.map.add(&shown, &text) else {
            self.diagnostics.push(messages::import_unreadable(
                span,
                written,
                &shown,
                "the imported files are too large together",
            ));
            return;
        };
        let (parsed, diags) = super::parse_at(&text, base);
        self.diagnostics.extend(diags);
        let Some(parsed) = parsed else {
            return;
        };
        self.stack.push(Open {
            path: canonical.clone(),
            import: Some(span),
        });
        let child_dir = joined.parent().map_or_else(PathBuf::new, Path::to_path_buf);
        self.imports(&parsed, &child_dir);
        self.stack.pop();
        self.items.extend(
            parsed
                .items
                .into_iter()
                .filter(|i| !matches!(i.kind, ItemKind::Import { .. } | ItemKind::Mesh { .. })),
        );
    }
}

/// Why a file cannot be read, in words that do not depend on the platform where they can.
fn why(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".to_string(),
        std::io::ErrorKind::PermissionDenied => "permission denied".to_string(),
        _ => e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh directory for one test, removed when it ends.
    fn scratch() -> tempfile::TempDir {
        tempfile::tempdir().expect("a temporary directory")
    }

    fn codes(parsed: &Parsed) -> Vec<&'static str> {
        parsed.diagnostics.iter().map(|d| d.code).collect()
    }

    #[test]
    fn a_chain_past_the_limit_is_reported_once() {
        let scratch = scratch();
        let dir = scratch.path();
        let n = MAX_IMPORT_DEPTH + 1;
        for k in 0..n {
            std::fs::write(
                dir.join(format!("f{k}.surf")),
                format!("import \"f{}.surf\";\nconst c{k} = {k};\n", k + 1),
            )
            .expect("write");
        }
        std::fs::write(dir.join(format!("f{n}.surf")), "const last = 1;\n").expect("write");
        let root = dir.join("root.surf");
        let text = "import \"f0.surf\";\n";
        let parsed = parse_with_imports("root.surf", Some(&root), text);
        assert_eq!(codes(&parsed), ["E0108"]);
        // It points into the last file read, at its import.
        let span = parsed.diagnostics[0].primary_span().expect("a span");
        let file = &parsed.map.files()[parsed.map.locate(span.start)];
        assert!(
            file.name
                .ends_with(&format!("f{}.surf", MAX_IMPORT_DEPTH - 1)),
            "{}",
            file.name
        );
    }

    #[test]
    fn a_file_imported_twice_is_read_once_and_a_self_import_is_a_cycle() {
        let scratch = scratch();
        let dir = scratch.path();
        std::fs::write(dir.join("units.surf"), "const unit = 1;\n").expect("write");
        std::fs::write(
            dir.join("a.surf"),
            "import \"units.surf\";\nconst a = unit;\n",
        )
        .expect("write");
        std::fs::write(
            dir.join("b.surf"),
            "import \"units.surf\";\nconst b = unit;\n",
        )
        .expect("write");
        let root = dir.join("root.surf");
        let text = "import \"a.surf\";\nimport \"b.surf\";\nconst c = a + b;\n";
        let parsed = parse_with_imports("root.surf", Some(&root), text);
        assert!(parsed.diagnostics.is_empty(), "{:?}", parsed.diagnostics);
        assert_eq!(parsed.map.files().len(), 4);
        let names: Vec<&str> = parsed
            .file
            .as_ref()
            .expect("parsed")
            .items
            .iter()
            .map(|i| i.kind.name().name.as_str())
            .collect();
        assert_eq!(names, ["unit", "a", "b", "c"]);
        // Everything imported lies past the root's text.
        let file = parsed.file.as_ref().expect("parsed");
        assert!(
            file.items[..3]
                .iter()
                .all(|i| i.span.start >= parsed.imported_from)
        );
        std::fs::write(&root, "import \"root.surf\";\n").expect("write");
        let parsed = parse_with_imports("root.surf", Some(&root), "import \"root.surf\";\n");
        assert_eq!(codes(&parsed), ["E0107"]);
        assert_eq!(parsed.diagnostics[0].labels.len(), 1);
    }
}
