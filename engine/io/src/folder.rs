//! Files a model names stay in the model's own folder: a glTF's buffers and images, an OBJ's `.mtl` libraries and
//! their texture maps. A model comes from anywhere (downloaded, sent by a stranger); a buffer URI of
//! `../../../../etc/passwd` made the glTF loader read that file as index data, so any file the user can read could
//! become geometry. The rule:
//!
//! - the name is resolved against the model's folder with every symbolic link resolved (the model's own path
//!   canonicalized), and must stay inside it: a `..` that climbs out is refused before anything is touched, and a
//!   path that leads out through a symbolic link (a link in the folder to `/etc`, or to a file outside) is refused
//!   once the links are resolved;
//! - absolute paths (`/etc/passwd`, `C:\x`, `\\server\x`) and `file:` URIs are refused whatever they name.
//!
//! Data URIs are not files: the glTF loader decodes them itself and never comes here. A scene file (`.toml`) is
//! the user's own description, so its paths may go anywhere; the models it loads keep this rule.

use std::path::{Component, Path, PathBuf};

use crate::InputError;

/// The canonical folder of a model file: the root every name the model gives must stay in.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ModelFolder {
    root: PathBuf,
}

impl ModelFolder {
    /// The folder of `model` (which must exist), every symbolic link on the way resolved.
    pub fn of(model: &Path) -> Result<Self, InputError> {
        let canonical = model.canonicalize().map_err(|e| InputError::io(model, e))?;
        let root = canonical.parent().map_or_else(|| PathBuf::from("/"), Path::to_path_buf);
        Ok(Self { root })
    }

    /// The folder itself (canonical).
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// `name`, a relative path as the model wrote it (a glTF URI already percent-decoded), resolved against
    /// `base` (a folder inside the root that an earlier [`resolve`](Self::resolve) gave, e.g. a `.mtl`'s folder
    /// for its texture maps; `None`: the root). The path to read, or why it is refused (one line, without the
    /// name: the caller names the model and quotes the name).
    pub fn resolve(&self, base: Option<&Path>, name: &str) -> Result<PathBuf, String> {
        check_form(name).map_err(|m| format!("{m}; {}", self.rule()))?;
        // Lexically first: `..` may climb back to the root, never above it. Nothing on disk is touched yet.
        let mut parts: Vec<&std::ffi::OsStr> = Vec::new();
        let start = base.and_then(|b| b.strip_prefix(&self.root).ok()).unwrap_or(Path::new(""));
        for c in start.components().chain(Path::new(name).components()) {
            match c {
                Component::Normal(p) => parts.push(p),
                Component::CurDir => {}
                Component::ParentDir => {
                    if parts.pop().is_none() {
                        return Err(format!("leads out of the model's folder with '..'; {}", self.rule()));
                    }
                }
                Component::RootDir | Component::Prefix(_) => {
                    return Err(format!("is an absolute path; {}", self.rule()));
                }
            }
        }
        let full: PathBuf = parts.iter().fold(self.root.clone(), |p, c| p.join(c));
        // Then through the links: the deepest part of the path that exists, resolved, must still be inside.
        let mut existing = full.as_path();
        loop {
            match existing.canonicalize() {
                Ok(real) => {
                    if !real.starts_with(&self.root) {
                        return Err(format!(
                            "leads out of the model's folder through a symbolic link (to {}); {}",
                            real.display(),
                            self.rule()
                        ));
                    }
                    // The file as resolved (when it exists): what is read is what was checked.
                    return Ok(if existing == full { real } else { full });
                }
                Err(_) => match existing.parent() {
                    Some(p) if p.starts_with(&self.root) && p != existing => existing = p,
                    _ => return Ok(full),
                },
            }
        }
    }

    fn rule(&self) -> String {
        format!("a model may name only files inside its own folder ({})", self.root.display())
    }
}

/// Names refused by their form alone: empty, NUL, a `file:` URI, an absolute path of any system.
fn check_form(name: &str) -> Result<(), String> {
    let lower = name.get(..5).map(str::to_ascii_lowercase);
    if name.is_empty() {
        Err("is empty".into())
    } else if name.contains('\0') {
        Err("contains a NUL byte".into())
    } else if lower.as_deref() == Some("file:") {
        Err("is a file: URI".into())
    } else if name.starts_with(['/', '\\']) {
        Err("is an absolute path".into())
    } else if name.len() >= 2 && name.as_bytes()[0].is_ascii_alphabetic() && name.as_bytes()[1] == b':' {
        Err("is an absolute path (a drive letter)".into())
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("engine-io-folder-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn names_inside_the_folder_resolve() {
        let d = temp("inside");
        std::fs::create_dir_all(d.join("sub")).unwrap();
        std::fs::write(d.join("model.gltf"), "{}").unwrap();
        std::fs::write(d.join("sub/a.bin"), "x").unwrap();
        let f = ModelFolder::of(&d.join("model.gltf")).unwrap();
        let root = d.canonicalize().unwrap();
        assert_eq!(f.root(), root);
        assert_eq!(f.resolve(None, "sub/a.bin").unwrap(), root.join("sub/a.bin"));
        assert_eq!(f.resolve(None, "./sub/../sub/a.bin").unwrap(), root.join("sub/a.bin"));
        // Not there yet: the path inside the folder (the read then says "file not found").
        assert_eq!(f.resolve(None, "missing/b.bin").unwrap(), root.join("missing/b.bin"));
        // Relative to a folder inside (a .mtl's texture maps).
        assert_eq!(f.resolve(Some(&root.join("sub")), "../sub/a.bin").unwrap(), root.join("sub/a.bin"));
        assert_eq!(f.resolve(Some(&root.join("sub")), "a.bin").unwrap(), root.join("sub/a.bin"));
    }

    #[test]
    fn traversal_absolute_paths_file_uris_and_links_out_are_refused() {
        let d = temp("out");
        std::fs::create_dir_all(d.join("model")).unwrap();
        std::fs::write(d.join("model/m.obj"), "").unwrap();
        std::fs::write(d.join("secret.txt"), "secret").unwrap();
        let f = ModelFolder::of(&d.join("model/m.obj")).unwrap();
        let refused = |base: Option<&Path>, name: &str, why: &str| {
            let e = f.resolve(base, name).unwrap_err();
            assert!(e.contains(why) && e.contains("inside its own folder"), "{name}: {e}");
        };
        refused(None, "../secret.txt", "leads out of the model's folder with '..'");
        refused(None, "../../../../etc/passwd", "with '..'");
        refused(None, "a/../../secret.txt", "with '..'");
        refused(Some(&f.root().join("sub")), "../../secret.txt", "with '..'");
        refused(None, "/etc/passwd", "is an absolute path");
        refused(None, "\\\\server\\share\\x", "is an absolute path");
        refused(None, "C:\\textures\\wood.png", "drive letter");
        refused(None, "file:///etc/passwd", "is a file: URI");
        refused(None, "FILE:secret.txt", "is a file: URI");
        refused(None, "", "is empty");
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(d.join("secret.txt"), d.join("model/link.bin")).unwrap();
            std::os::unix::fs::symlink(&d, d.join("model/up")).unwrap();
            refused(None, "link.bin", "through a symbolic link");
            refused(None, "up/secret.txt", "through a symbolic link");
            // A link out to a folder, and a file not (yet) there behind it.
            refused(None, "up/not-there.bin", "through a symbolic link");
            // A link that stays inside is followed.
            std::os::unix::fs::symlink(f.root().join("m.obj"), d.join("model/same.obj")).unwrap();
            assert_eq!(f.resolve(None, "same.obj").unwrap(), f.root().join("m.obj"));
            // A model reached through a link: its folder is where the file really is.
            std::fs::create_dir_all(d.join("elsewhere")).unwrap();
            std::os::unix::fs::symlink(d.join("model/m.obj"), d.join("elsewhere/m.obj")).unwrap();
            assert_eq!(ModelFolder::of(&d.join("elsewhere/m.obj")).unwrap().root(), f.root());
        }
    }
}
