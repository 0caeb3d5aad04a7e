//! The manifest of an artifact and the digests it is made of.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, read_input};
use crate::io::fs::file_digest;

pub const MANIFEST: &str = "manifest.json";
pub const RUN_INFO: &str = "run.json";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FileEntry {
    /// Relative to the artifact folder, with '/' separators.
    pub path: String,
    pub role: String,
    pub size: u64,
    pub digest: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputDigest {
    pub path: String,
    pub digest: String,
}

/// How an artifact was made.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Lineage {
    pub stage: String,
    pub stage_version: u32,
    pub stage_key: String,
    pub tool_version: String,
    pub params: serde_json::Value,
    pub inputs: Vec<InputDigest>,
}

impl Lineage {
    /// Lineage of a stage run; the key digests everything that determines the output.
    pub fn new(
        stage: &str,
        stage_version: u32,
        params: serde_json::Value,
        inputs: Vec<InputDigest>,
    ) -> Self {
        let tool_version = env!("CARGO_PKG_VERSION").to_string();
        let stage_key = stage_key(stage, stage_version, &params, &inputs, &tool_version);
        Lineage {
            stage: stage.into(),
            stage_version,
            stage_key,
            tool_version,
            params,
            inputs,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub kind: String,
    pub name: String,
    pub schema: String,
    pub schema_version: String,
    /// blake3 over the sorted list of (path, size, file digest).
    pub digest: String,
    pub files: Vec<FileEntry>,
    pub lineage: Lineage,
    pub metrics: serde_json::Value,
}

impl Manifest {
    pub fn files_with_role<'a>(
        &'a self,
        role: &'a str,
    ) -> impl Iterator<Item = &'a FileEntry> + 'a {
        self.files.iter().filter(move |f| f.role == role)
    }
}

/// The artifact digest of a list of files (sorted here, so order does not matter).
pub fn artifact_digest(files: &[FileEntry]) -> String {
    let mut sorted: Vec<&FileEntry> = files.iter().collect();
    sorted.sort_by(|a, b| a.path.cmp(&b.path));
    let mut hasher = blake3::Hasher::new();
    for f in sorted {
        hasher.update(f.path.as_bytes());
        hasher.update(b"\0");
        hasher.update(f.size.to_string().as_bytes());
        hasher.update(b"\0");
        hasher.update(f.digest.as_bytes());
        hasher.update(b"\n");
    }
    format!("blake3:{}", hasher.finalize().to_hex())
}

/// Digest of canonical JSON (sorted keys, no whitespace) of what determines a stage's output.
pub fn stage_key(
    stage: &str,
    stage_version: u32,
    params: &serde_json::Value,
    inputs: &[InputDigest],
    tool_version: &str,
) -> String {
    let canonical = serde_json::json!({
        "stage": stage,
        "stage_version": stage_version,
        "params": params,
        "inputs": inputs,
        "tool_version": tool_version,
    });
    format!(
        "blake3:{}",
        blake3::hash(canonical.to_string().as_bytes()).to_hex()
    )
}

/// Reads and checks an artifact's manifest, and checks its files against their
/// digests; `kind` is the kind expected.
pub fn read_manifest(dir: &Path, kind: &str) -> Result<Manifest> {
    let path = dir.join(MANIFEST);
    if !dir.is_dir() {
        return Err(Error::input(
            dir,
            format!("no such artifact folder (expected a '{kind}' artifact)"),
        ));
    }
    let bytes = read_input(&path)?;
    let manifest: Manifest = serde_json::from_slice(&bytes)
        .map_err(|e| Error::input(&path, format!("not a valid manifest: {e}")))?;
    if manifest.kind != kind {
        return Err(Error::input(
            &path,
            format!(
                "is a '{}' artifact, expected a '{kind}' artifact",
                manifest.kind
            ),
        ));
    }
    if manifest.schema_version.split('.').next() != Some("1") {
        return Err(Error::input(
            &path,
            format!(
                "schema version {} is not supported (this imitate reads 1.x)",
                manifest.schema_version
            ),
        ));
    }
    super::verify::verify_entries(dir, &manifest.files)?;
    Ok(manifest)
}

/// A plain folder's digest (a dataset someone else made, e.g. LeRobot): blake3 of the
/// sorted list of its files' relative paths and content digests.
fn folder_digest(
    folder: &Path,
    digest_file: &mut dyn FnMut(&Path) -> Result<String>,
) -> Result<String> {
    fn walk(dir: &Path, files: &mut Vec<std::path::PathBuf>) -> Result<()> {
        let entries = std::fs::read_dir(dir)
            .map_err(|e| Error::input(dir, format!("cannot list the folder: {e}")))?;
        for entry in entries {
            let path = entry
                .map_err(|e| Error::input(dir, format!("cannot list the folder: {e}")))?
                .path();
            if path.is_dir() {
                walk(&path, files)?;
            } else {
                files.push(path);
            }
        }
        Ok(())
    }
    let mut files = Vec::new();
    walk(folder, &mut files)?;
    files.sort();
    let mut listing = String::new();
    for file in &files {
        let relative = file.strip_prefix(folder).unwrap_or(file);
        listing += &format!(
            "{}\t{}\n",
            relative.to_string_lossy().replace('\\', "/"),
            digest_file(file)?
        );
    }
    Ok(format!(
        "blake3:{}",
        blake3::hash(listing.as_bytes()).to_hex()
    ))
}

/// An input's digest: an artifact folder's manifest digest, a plain folder's digest of
/// its files, or a file's content digest.
/// The path is recorded as the user gave it, so that lineage does not depend on where
/// a checkout lives.
pub fn digest_input(path: &Path) -> Result<InputDigest> {
    digest_input_with(path, &mut |file| {
        file_digest(file).map(|(digest, _)| digest)
    })
}

/// As `digest_input`, with files digested by `digest_file` (e.g. through a stat cache).
pub fn digest_input_with(
    path: &Path,
    digest_file: &mut dyn FnMut(&Path) -> Result<String>,
) -> Result<InputDigest> {
    let digest = if path.is_dir() && !path.join(MANIFEST).exists() {
        folder_digest(path, digest_file)?
    } else if path.is_dir() {
        let bytes = read_input(&path.join(MANIFEST))?;
        let manifest: Manifest = serde_json::from_slice(&bytes)
            .map_err(|e| Error::input(path.join(MANIFEST), format!("not a valid manifest: {e}")))?;
        manifest.digest
    } else {
        digest_file(path)?
    };
    Ok(InputDigest {
        path: path.to_string_lossy().replace('\\', "/"),
        digest,
    })
}
