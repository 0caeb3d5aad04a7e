//! Builds an artifact in a temporary folder beside its destination and moves it into
//! place only when complete, so a crash never leaves a half-written artifact.

use std::path::{Path, PathBuf};

use super::guard::{check_relative, check_replaceable};
use super::manifest::{FileEntry, Lineage, MANIFEST, Manifest, RUN_INFO, artifact_digest};
use crate::error::{Error, Result};
use crate::io::fs::{file_digest, to_json_bytes, write_bytes_atomic};
use crate::io::leftovers;

pub struct ArtifactBuilder {
    destination: PathBuf,
    staging: Staging,
    files: Vec<(String, String)>,
    started: std::time::Instant,
}

impl ArtifactBuilder {
    pub fn new(destination: &Path) -> Result<Self> {
        check_replaceable(destination)?;
        let staging = staging_beside(destination)?;
        Ok(ArtifactBuilder {
            destination: destination.to_path_buf(),
            staging,
            files: Vec::new(),
            started: std::time::Instant::now(),
        })
    }

    /// Where to write the file `relative` (with '/' separators), recorded with its role.
    /// Refuses names that would leave the artifact (see [`check_relative`]).
    pub fn file(&mut self, relative: &str, role: &str) -> Result<PathBuf> {
        check_relative(relative)?;
        let path = self.staging.dir.path().join(relative);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir)
                .map_err(|e| Error::io(format!("creating {}", dir.display()), e))?;
        }
        self.files.push((relative.to_string(), role.to_string()));
        Ok(path)
    }

    /// Writes the manifest and `run.json`, then moves the folder into place. The
    /// artifact is named after its folder.
    pub fn commit(
        self,
        kind: &str,
        lineage: Lineage,
        metrics: serde_json::Value,
    ) -> Result<Manifest> {
        let name = self
            .destination
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut files = Vec::with_capacity(self.files.len());
        for (relative, role) in &self.files {
            let (digest, size) = file_digest(&self.staging.dir.path().join(relative))?;
            files.push(FileEntry {
                path: relative.clone(),
                role: role.clone(),
                size,
                digest,
            });
        }
        files.sort_by(|a, b| a.path.cmp(&b.path));
        let manifest = Manifest {
            kind: kind.into(),
            name,
            schema: format!("imitate.{kind}"),
            schema_version: "1.0.0".into(),
            digest: artifact_digest(&files),
            files,
            lineage,
            metrics,
        };
        write_bytes_atomic(
            &self.staging.dir.path().join(MANIFEST),
            &to_json_bytes(&manifest),
        )?;
        let finished = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default();
        let run = serde_json::json!({
            "finished_unix_s": finished.as_secs(),
            "finished_unix_ms": finished.as_millis() as u64,
            "duration_s": self.started.elapsed().as_secs_f64(),
            "threads": rayon::current_num_threads(),
        });
        write_bytes_atomic(
            &self.staging.dir.path().join(RUN_INFO),
            &to_json_bytes(&run),
        )?;
        install(self.staging, &self.destination)?;
        Ok(manifest)
    }
}

/// Copies the artifact folder `from` to `to`, atomically like a commit: into a staging
/// folder beside `to` first, then moved into place.
pub fn copy_artifact(from: &Path, to: &Path) -> Result<()> {
    let staging = staging_beside(to)?;
    copy_tree(from, staging.dir.path())?;
    install(staging, to)
}

fn copy_tree(from: &Path, to: &Path) -> Result<()> {
    let entries =
        std::fs::read_dir(from).map_err(|e| Error::io(format!("reading {}", from.display()), e))?;
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(format!("reading {}", from.display()), e))?;
        let (source, target) = (entry.path(), to.join(entry.file_name()));
        if source.is_dir() {
            std::fs::create_dir_all(&target)
                .map_err(|e| Error::io(format!("creating {}", target.display()), e))?;
            copy_tree(&source, &target)?;
        } else {
            std::fs::copy(&source, &target).map_err(|e| {
                Error::io(
                    format!("copying {} to {}", source.display(), target.display()),
                    e,
                )
            })?;
        }
    }
    Ok(())
}

/// A staging folder, locked by this process while it lives so that no sweep takes it
/// for a killed run's leftover.
struct Staging {
    dir: tempfile::TempDir,
    _held: Option<std::fs::File>,
}

/// A new, empty staging folder in the folder that will hold `destination`, so that
/// moving it into place is a rename within one file system. Leftovers of killed runs
/// in that folder are swept first.
fn staging_beside(destination: &Path) -> Result<Staging> {
    let parent = match destination.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&parent)
        .map_err(|e| Error::io(format!("creating {}", parent.display()), e))?;
    leftovers::sweep(&parent, &leftovers::BESIDE_OUTPUTS);
    let (dir, held) = leftovers::claimed(|| {
        let dir = tempfile::Builder::new()
            .prefix(leftovers::STAGING)
            .tempdir_in(&parent)?;
        let held = leftovers::hold(dir.path());
        Ok((dir, held))
    })
    .map_err(|e| {
        Error::io(
            format!("creating a staging folder in {}", parent.display()),
            e,
        )
    })?;
    Ok(Staging { dir, _held: held })
}

/// Replaces `destination` with the staged folder: the old version is moved aside,
/// the new one renamed in, then the old one removed. What is there is checked again
/// first: something may have appeared since the work began.
fn install(staging: Staging, destination: &Path) -> Result<()> {
    check_replaceable(destination)?;
    let Staging { dir, _held } = staging;
    let staged = dir.keep();
    crate::io::fs::set_public_permissions(&staged, 0o755)?;
    let parent = staged
        .parent()
        .expect("staging folders live in a parent")
        .to_path_buf();
    let rename = |from: &Path, to: &Path| {
        std::fs::rename(from, to)
            .map_err(|e| Error::io(format!("moving {} to {}", from.display(), to.display()), e))
    };
    let result = if destination.exists() {
        let (retired, _retired_held) = leftovers::claimed(|| {
            let retired = tempfile::Builder::new()
                .prefix(leftovers::RETIRED)
                .tempdir_in(&parent)?
                .keep();
            let held = leftovers::hold(&retired);
            Ok::<_, std::io::Error>((retired, held))
        })
        .map_err(|e| Error::io(format!("creating a folder in {}", parent.display()), e))?;
        let old = retired.join("old");
        let result = rename(destination, &old).and_then(|_| {
            rename(&staged, destination).inspect_err(|_| {
                // Put the old version back rather than leave nothing.
                let _ = std::fs::rename(&old, destination);
            })
        });
        // Kept only when the old version could not be put back: it is all there is.
        if result.is_ok() || !old.exists() {
            let _ = std::fs::remove_dir_all(&retired);
        }
        result
    } else {
        rename(&staged, destination)
    };
    if result.is_err() {
        let _ = std::fs::remove_dir_all(&staged);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lineage() -> Lineage {
        Lineage::new("test", 1, serde_json::json!({"a": 1}), vec![])
    }

    #[test]
    fn commits_replace_atomically_and_digests_are_stable() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("art");
        let build = |content: &[u8]| {
            let mut b = ArtifactBuilder::new(&dest).unwrap();
            let p = b.file("sub/x.txt", "data").unwrap();
            std::fs::write(p, content).unwrap();
            b.commit("thing", lineage(), serde_json::json!({})).unwrap()
        };
        let first = build(b"one");
        let again = build(b"one");
        assert_eq!(first.digest, again.digest);
        let other = build(b"two");
        assert_ne!(first.digest, other.digest);
        assert_eq!(std::fs::read(dest.join("sub/x.txt")).unwrap(), b"two");
        let leftovers: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(leftovers, vec![std::ffi::OsString::from("art")]);
        let read = super::super::read_manifest(&dest, "thing").unwrap();
        assert_eq!(read, other);
        assert!(super::super::read_manifest(&dest, "costmap").is_err());
    }

    #[test]
    fn a_dropped_builder_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("art");
        {
            let mut b = ArtifactBuilder::new(&dest).unwrap();
            std::fs::write(b.file("x", "data").unwrap(), b"x").unwrap();
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
