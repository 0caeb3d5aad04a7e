//! Checks files against the digests their manifest records, so that a flipped byte in
//! an artifact or a DAgger round is refused with the file's name instead of silently
//! changing what is learned from it.

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::Serialize;

use super::manifest::{FileEntry, MANIFEST, RUN_INFO};
use crate::error::{Error, Result};
use crate::io::fs::file_digest;

/// What is wrong with one file of a folder, against its manifest.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Problem {
    /// Relative to the folder, '/'-separated.
    pub path: String,
    pub problem: String,
}

/// The result of checking a whole folder.
#[derive(Debug, Clone, Serialize)]
pub struct Verification {
    pub folder: PathBuf,
    pub kind: String,
    pub files: usize,
    pub bytes: u64,
    /// Listed files that are missing, of another size or another digest.
    pub problems: Vec<Problem>,
    /// Files in the folder that the manifest does not list (not read by imitate).
    pub unlisted: Vec<String>,
}

/// What `entry` finds wrong with the file at `path`, if anything.
fn check(path: &Path, entry: &FileEntry) -> Option<String> {
    let size = match std::fs::metadata(path) {
        Ok(m) if m.is_file() => m.len(),
        Ok(_) => return Some("is not a file".into()),
        Err(_) => return Some("is missing".into()),
    };
    if size != entry.size {
        return Some(format!(
            "holds {size} bytes, the manifest records {}",
            entry.size
        ));
    }
    match file_digest(path) {
        Ok((digest, _)) if digest == entry.digest => None,
        Ok((digest, _)) => Some(format!(
            "has digest {digest}, the manifest records {}",
            entry.digest
        )),
        Err(e) => Some(format!("cannot be read: {e}")),
    }
}

/// Checks the files `entries` of `dir` (in parallel); the first problem in manifest
/// order is an input error naming the file.
pub fn verify_entries(dir: &Path, entries: &[FileEntry]) -> Result<()> {
    let problems: Vec<Option<String>> = entries
        .par_iter()
        .map(|entry| check(&dir.join(&entry.path), entry))
        .collect();
    match entries
        .iter()
        .zip(problems)
        .find_map(|(e, p)| p.map(|p| (e, p)))
    {
        None => Ok(()),
        Some((entry, problem)) => Err(damaged(dir, &entry.path, &problem)),
    }
}

/// Checks one file of `dir` against the manifest entry for `relative`.
pub fn verify_entry(dir: &Path, entries: &[FileEntry], relative: &str) -> Result<()> {
    let entry = entries.iter().find(|e| e.path == relative).ok_or_else(|| {
        Error::input(
            dir.join(relative),
            format!(
                "is not listed in the manifest of {}: the folder is damaged",
                dir.display()
            ),
        )
    })?;
    match check(&dir.join(relative), entry) {
        None => Ok(()),
        Some(problem) => Err(damaged(dir, relative, &problem)),
    }
}

fn damaged(dir: &Path, relative: &str, problem: &str) -> Error {
    Error::input(
        dir.join(relative),
        format!(
            "{problem}: the file was changed or damaged after imitate wrote it \
             (`imitate verify {}` lists every such file)",
            dir.display()
        ),
    )
}

/// Checks every file a folder's manifest lists, and finds the files it holds that the
/// manifest does not list (besides `manifest.json` and `run.json`).
pub fn verify_folder(dir: &Path) -> Result<Verification> {
    #[derive(serde::Deserialize)]
    struct Listing {
        kind: String,
        files: Vec<FileEntry>,
    }
    let manifest = dir.join(MANIFEST);
    let bytes = std::fs::read(&manifest).map_err(|_| {
        Error::input(
            dir,
            "is not an artifact or DAgger dataset folder (no manifest.json)",
        )
    })?;
    let listing: Listing = serde_json::from_slice(&bytes)
        .map_err(|e| Error::input(&manifest, format!("is not a valid manifest: {e}")))?;
    let found: Vec<Option<String>> = listing
        .files
        .par_iter()
        .map(|entry| check(&dir.join(&entry.path), entry))
        .collect();
    let problems: Vec<Problem> = listing
        .files
        .iter()
        .zip(found)
        .filter_map(|(entry, problem)| {
            problem.map(|problem| Problem {
                path: entry.path.clone(),
                problem,
            })
        })
        .collect();
    let mut present = Vec::new();
    list_files(dir, dir, &mut present)?;
    present.retain(|relative| {
        relative != MANIFEST
            && relative != RUN_INFO
            && !listing.files.iter().any(|e| &e.path == relative)
    });
    Ok(Verification {
        folder: dir.to_path_buf(),
        kind: listing.kind,
        files: listing.files.len(),
        bytes: listing.files.iter().map(|e| e.size).sum(),
        problems,
        unlisted: present,
    })
}

/// Every file under `dir`, relative to `root` with '/' separators, sorted.
fn list_files(root: &Path, dir: &Path, out: &mut Vec<String>) -> Result<()> {
    let entries =
        std::fs::read_dir(dir).map_err(|e| Error::input(dir, format!("cannot be listed: {e}")))?;
    let mut paths: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
    paths.sort();
    for path in paths {
        if path.is_dir() {
            list_files(root, &path, out)?;
        } else {
            let relative = path.strip_prefix(root).unwrap_or(&path);
            out.push(relative.to_string_lossy().replace('\\', "/"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::artifact::{ArtifactBuilder, Lineage};

    #[test]
    fn finds_flipped_missing_and_extra_files() {
        let dir = tempfile::tempdir().unwrap();
        let art = dir.path().join("art");
        let mut b = ArtifactBuilder::new(&art).unwrap();
        std::fs::write(b.file("a.txt", "data").unwrap(), b"alpha").unwrap();
        std::fs::write(b.file("sub/b.txt", "data").unwrap(), b"beta").unwrap();
        let lineage = Lineage::new("test", 1, serde_json::json!({}), vec![]);
        let manifest = b.commit("thing", lineage, serde_json::json!({})).unwrap();
        let clean = verify_folder(&art).unwrap();
        assert!(clean.problems.is_empty(), "{:?}", clean.problems);
        assert_eq!((clean.files, clean.bytes), (2, 9));
        verify_entries(&art, &manifest.files).unwrap();

        std::fs::write(art.join("a.txt"), b"alphA").unwrap();
        std::fs::remove_file(art.join("sub/b.txt")).unwrap();
        std::fs::write(art.join("stray.txt"), b"?").unwrap();
        let found = verify_folder(&art).unwrap();
        let problems: Vec<(&str, &str)> = found
            .problems
            .iter()
            .map(|p| (p.path.as_str(), p.problem.split(' ').next().unwrap()))
            .collect();
        assert_eq!(problems, [("a.txt", "has"), ("sub/b.txt", "is")]);
        assert_eq!(found.unlisted, ["stray.txt"]);
        let err = verify_entries(&art, &manifest.files)
            .unwrap_err()
            .to_string();
        assert!(err.contains("a.txt") && err.contains("digest"), "{err}");
        let err = verify_entry(&art, &manifest.files, "sub/b.txt")
            .unwrap_err()
            .to_string();
        assert!(err.contains("is missing"), "{err}");
    }
}
