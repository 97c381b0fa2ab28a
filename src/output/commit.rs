//! The outputs of one run, written all or nothing.
//!
//! A run that writes several files (an EXR, a PNG, a record map, a stats JSON) must not
//! leave some of them written, or an older file replaced, when it then fails: a user who
//! sees "error" trusts that nothing changed. [`OutputSet`] checks every path before the
//! work starts (its directory exists and takes a new file there, it names no device or
//! FIFO; a symbolic link is written through to its target), writes each file's bytes to a
//! temporary file beside it once they are ready, and renames them all into place only in
//! [`OutputSet::commit`], after every file was staged. Dropped without a commit, it removes
//! its temporary files and leaves every existing output as it was. No temporary file exists
//! while the work runs, so a run stopped by a signal (Ctrl-C) leaves none behind.

use crate::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// One planned output: the path it was named by, the file it replaces (the path, or a
/// symbolic link's target) and the temporary file that holds it until commit.
struct Planned {
    path: PathBuf,
    target: PathBuf,
    tmp: PathBuf,
    staged: bool,
}

/// Every file one run writes, committed together (see the module doc).
#[derive(Default)]
pub struct OutputSet {
    planned: Vec<Planned>,
}

impl OutputSet {
    /// An empty set.
    pub fn new() -> OutputSet {
        OutputSet::default()
    }

    /// Plans `path` as an output of this run, before any work: refuses a path named twice,
    /// a directory, a device, FIFO or socket ([`super::output_target`]), a missing
    /// directory or one that does not take a new file (a temporary file is created and
    /// removed now, so permissions show up before rendering rather than after it).
    pub fn plan(&mut self, path: &Path) -> Result<()> {
        let err = |message: String| Error::Output {
            path: path.to_path_buf(),
            message,
        };
        let target = super::output_target(path)?;
        if self
            .planned
            .iter()
            .any(|p| same_file(&p.path, path) || same_file(&p.target, &target))
        {
            return Err(err(
                "named twice as an output of this run: each output needs its own path".into(),
            ));
        }
        let dir = super::output_dir(&target)?;
        let file_name = target
            .file_name()
            .ok_or_else(|| err("not a file name".into()))?
            .to_string_lossy();
        let tmp = dir.join(format!(
            ".{file_name}.{}.{}.tmp",
            std::process::id(),
            self.planned.len()
        ));
        std::fs::File::create(&tmp).map_err(|e| err(format!("cannot be written: {e}")))?;
        let _ = std::fs::remove_file(&tmp);
        self.planned.push(Planned {
            path: path.to_path_buf(),
            target,
            tmp,
            staged: false,
        });
        Ok(())
    }

    /// Plans `path` when there is one (an optional output flag).
    pub fn plan_opt(&mut self, path: Option<&Path>) -> Result<()> {
        match path {
            Some(p) => self.plan(p),
            None => Ok(()),
        }
    }

    /// Whether `path` was planned.
    pub fn is_planned(&self, path: &Path) -> bool {
        self.planned.iter().any(|p| same_file(&p.path, path))
    }

    /// Writes the bytes of the planned output `path` to its temporary file (fsynced); the
    /// file itself is replaced only by [`OutputSet::commit`].
    pub fn stage(&mut self, path: &Path, bytes: &[u8]) -> Result<()> {
        let planned = self.planned_mut(path)?;
        let result = (|| -> std::io::Result<()> {
            let mut f = std::fs::File::create(&planned.tmp)?;
            f.write_all(bytes)?;
            f.sync_all()
        })();
        result.map_err(|e| Error::Output {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        planned.staged = true;
        Ok(())
    }

    /// Stages the planned output `path` by letting `write` write its temporary file (for
    /// writers that take a path; their errors name the temporary file).
    pub fn stage_with(
        &mut self,
        path: &Path,
        write: impl FnOnce(&Path) -> Result<()>,
    ) -> Result<()> {
        let planned = self.planned_mut(path)?;
        write(&planned.tmp)?;
        planned.staged = true;
        Ok(())
    }

    /// The planned output `path`.
    fn planned_mut(&mut self, path: &Path) -> Result<&mut Planned> {
        self.planned
            .iter_mut()
            .find(|p| same_file(&p.path, path))
            .ok_or_else(|| Error::Output {
                path: path.to_path_buf(),
                message: "internal: staged without being planned".into(),
            })
    }

    /// Renames every staged file into place. Fails, replacing nothing, when a planned
    /// output was never staged (the run did not produce everything it promised).
    pub fn commit(self) -> Result<()> {
        if let Some(p) = self.planned.iter().find(|p| !p.staged) {
            return Err(Error::Output {
                path: p.path.clone(),
                message: "internal: planned but never written; no output was replaced".into(),
            });
        }
        for p in &self.planned {
            std::fs::rename(&p.tmp, &p.target).map_err(|e| Error::Output {
                path: p.path.clone(),
                message: e.to_string(),
            })?;
        }
        Ok(())
    }
}

impl Drop for OutputSet {
    /// Removes the temporary files of a set that was not committed (or, when its commit
    /// failed part way, of what was not renamed yet).
    fn drop(&mut self) {
        for p in &self.planned {
            // A renamed file's temporary name is gone already, and an unstaged one may
            // never have been written: nothing to remove then (the name is this
            // process's own).
            let _ = std::fs::remove_file(&p.tmp);
        }
    }
}

/// Whether two output paths name the same file (literally, or after resolving the
/// directory, so `out.exr` and `./out.exr` collide).
fn same_file(a: &Path, b: &Path) -> bool {
    if a == b {
        return true;
    }
    let resolve = |p: &Path| -> Option<PathBuf> {
        let dir = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        Some(dir.canonicalize().ok()?.join(p.file_name()?))
    };
    matches!((resolve(a), resolve(b)), (Some(x), Some(y)) if x == y)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh directory for one test, removed when dropped (a set of them was left in the
    /// temp dir by every run).
    struct TmpDir(PathBuf);

    impl std::ops::Deref for TmpDir {
        type Target = Path;
        fn deref(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for TmpDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn tmp_dir(name: &str) -> TmpDir {
        let d = std::env::temp_dir().join(format!("radsplat-commit-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("temp dir");
        TmpDir(d)
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .expect("dir")
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn all_outputs_appear_together_on_commit() {
        let dir = tmp_dir("commit");
        let (a, b) = (dir.join("a.exr"), dir.join("b.png"));
        let mut set = OutputSet::new();
        set.plan(&a).expect("plan a");
        set.plan(&b).expect("plan b");
        set.stage(&a, b"A").expect("stage a");
        set.stage(&b, b"B").expect("stage b");
        assert!(
            !a.exists() && !b.exists(),
            "nothing is in place before commit"
        );
        set.commit().expect("commit");
        assert_eq!(std::fs::read(&a).expect("a"), b"A");
        assert_eq!(std::fs::read(&b).expect("b"), b"B");
        assert_eq!(entries(&dir), ["a.exr", "b.png"], "no temporary file left");
    }

    #[test]
    fn a_set_dropped_before_commit_changes_nothing() {
        let dir = tmp_dir("drop");
        let a = dir.join("a.exr");
        std::fs::write(&a, b"old").expect("old file");
        {
            let mut set = OutputSet::new();
            set.plan(&a).expect("plan");
            set.stage(&a, b"new").expect("stage");
            // The run fails here: the set is dropped.
        }
        assert_eq!(std::fs::read(&a).expect("a"), b"old");
        assert_eq!(entries(&dir), ["a.exr"], "no temporary file left");
    }

    /// A device or FIFO is refused before any work (renaming a file into place would have
    /// replaced `/dev/null` itself); a symbolic link is written through: its target gets
    /// the output and the link stays.
    #[cfg(unix)]
    #[test]
    fn devices_are_refused_and_links_written_through() {
        let dir = tmp_dir("special");
        let mut set = OutputSet::new();
        let e = set
            .plan(Path::new("/dev/null"))
            .expect_err("a device")
            .to_string();
        assert!(
            e.contains("/dev/null") && e.contains("not a regular file"),
            "{e}"
        );
        let fifo = dir.join("fifo");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            let e = set.plan(&fifo).expect_err("a FIFO").to_string();
            assert!(e.contains("not a regular file"), "{e}");
            std::fs::remove_file(&fifo).expect("remove fifo");
        }
        let target = dir.join("real.json");
        std::fs::write(&target, b"old").expect("target");
        let link = dir.join("link.json");
        std::os::unix::fs::symlink("real.json", &link).expect("symlink");
        set.plan(&link).expect("plan the link");
        let e = set
            .plan(&target)
            .expect_err("the link's target is the same output")
            .to_string();
        assert!(e.contains("twice"), "{e}");
        set.stage(&link, b"new").expect("stage");
        set.commit().expect("commit");
        assert!(
            std::fs::symlink_metadata(&link)
                .expect("link")
                .file_type()
                .is_symlink(),
            "the link stays a link"
        );
        assert_eq!(std::fs::read(&target).expect("target"), b"new");
        // A dangling link: the file it names is created.
        let dangling = dir.join("dangling.png");
        std::os::unix::fs::symlink("made.png", &dangling).expect("symlink");
        write_through(&dangling);
        assert_eq!(std::fs::read(dir.join("made.png")).expect("made"), b"x");
        assert_eq!(
            entries(&dir),
            ["dangling.png", "link.json", "made.png", "real.json"],
            "no temporary file left"
        );
    }

    #[cfg(unix)]
    fn write_through(path: &Path) {
        let mut set = OutputSet::new();
        set.plan(path).expect("plan");
        set.stage(path, b"x").expect("stage");
        set.commit().expect("commit");
    }

    /// Planning leaves no file behind: a run stopped during its work (a signal, which runs
    /// no destructor) leaves the output directory as it was.
    #[test]
    fn planning_leaves_no_file_behind() {
        let dir = tmp_dir("plan");
        let mut set = OutputSet::new();
        set.plan(&dir.join("a.exr")).expect("plan");
        assert!(entries(&dir).is_empty(), "{:?}", entries(&dir));
        std::mem::forget(set); // as a signal would: no drop
        assert!(entries(&dir).is_empty(), "{:?}", entries(&dir));
    }

    #[test]
    fn bad_paths_are_refused_when_planned() {
        let dir = tmp_dir("bad");
        let mut set = OutputSet::new();
        let missing = dir.join("nodir").join("x.png");
        let e = set.plan(&missing).expect_err("missing dir").to_string();
        assert!(e.contains("nodir") && e.contains("does not exist"), "{e}");
        let e = set.plan(&dir).expect_err("a directory").to_string();
        assert!(e.contains("directory"), "{e}");
        set.plan(&dir.join("a.exr")).expect("plan");
        let e = set
            .plan(&dir.join(".").join("a.exr"))
            .expect_err("twice")
            .to_string();
        assert!(e.contains("twice"), "{e}");
        // A planned output never staged: the commit fails and writes nothing.
        let e = set.commit().expect_err("unstaged").to_string();
        assert!(e.contains("never written"), "{e}");
        assert!(entries(&dir).is_empty(), "{:?}", entries(&dir));
    }
}
