//! The lock file: for each stage of a pipeline, the lineage of its last run and the
//! digest of the output it made. Canonical (sorted keys, no timestamps), so identical
//! runs write identical lock files and they diff well in version control.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::artifact::Lineage;
use crate::error::{Error, Result};
use crate::io::fs::{to_json_bytes, write_bytes_atomic};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LockedStage {
    pub lineage: Lineage,
    pub out: String,
    pub out_digest: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LockFile {
    pub schema: u32,
    pub stages: BTreeMap<String, LockedStage>,
}

impl Default for LockFile {
    fn default() -> Self {
        LockFile {
            schema: 1,
            stages: BTreeMap::new(),
        }
    }
}

/// `pipelines/x.yaml` locks into `pipelines/x.lock` (`imitate.yaml` into `imitate.lock`).
pub fn lock_path(pipeline: &Path) -> PathBuf {
    pipeline.with_extension("lock")
}

/// The lock file, or an empty one when the pipeline never ran.
pub fn read(path: &Path) -> Result<LockFile> {
    match std::fs::read(path) {
        Ok(bytes) => {
            let lock: LockFile = serde_json::from_slice(&bytes).map_err(|e| {
                Error::input(
                    path,
                    format!("not a valid lock file ({e}); delete it to rerun every stage"),
                )
            })?;
            if lock.schema != 1 {
                return Err(Error::input(
                    path,
                    format!("lock file schema {} is not supported", lock.schema),
                ));
            }
            Ok(lock)
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(LockFile::default()),
        Err(e) => Err(Error::input(path, e.to_string())),
    }
}

pub fn write(path: &Path, lock: &LockFile) -> Result<()> {
    write_bytes_atomic(path, &to_json_bytes(lock))
}

/// Why a stage must run again, in words: every difference between the lineage it ran
/// with and the lineage it would run with now.
pub fn differences(stage: &str, before: &Lineage, now: &Lineage) -> Vec<String> {
    let mut reasons = Vec::new();
    if before.tool_version != now.tool_version {
        reasons.push(format!(
            "tool version changed: {} → {}",
            before.tool_version, now.tool_version
        ));
    }
    if before.stage_version != now.stage_version {
        reasons.push(format!(
            "stage version changed: {} → {}",
            before.stage_version, now.stage_version
        ));
    }
    let empty = serde_json::Map::new();
    let (old, new) = (
        before.params.as_object().unwrap_or(&empty),
        now.params.as_object().unwrap_or(&empty),
    );
    let keys: std::collections::BTreeSet<&String> = old.keys().chain(new.keys()).collect();
    for key in keys {
        let (a, b) = (old.get(key), new.get(key));
        if a != b {
            let show =
                |v: Option<&serde_json::Value>| v.map_or("(none)".to_string(), |v| v.to_string());
            reasons.push(format!(
                "param changed: {stage}.{key} {} → {}",
                show(a),
                show(b)
            ));
        }
    }
    let old_inputs: BTreeMap<&str, &str> = before
        .inputs
        .iter()
        .map(|i| (i.path.as_str(), i.digest.as_str()))
        .collect();
    for input in &now.inputs {
        match old_inputs.get(input.path.as_str()) {
            None => reasons.push(format!("input added: {}", input.path)),
            Some(&digest) if digest != input.digest => {
                reasons.push(format!("input changed: {}", input.path))
            }
            Some(_) => {}
        }
    }
    for path in old_inputs.keys() {
        if !now.inputs.iter().any(|i| i.path == *path) {
            reasons.push(format!("input removed: {path}"));
        }
    }
    reasons
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::artifact::InputDigest;

    fn lineage(rounds: u32, digest: &str) -> Lineage {
        let input = InputDigest {
            path: "a.parquet".into(),
            digest: digest.into(),
        };
        Lineage::new(
            "learch",
            1,
            serde_json::json!({"rounds": rounds, "seed": 0}),
            vec![input],
        )
    }

    #[test]
    fn differences_name_params_and_inputs() {
        assert!(differences("s", &lineage(40, "x"), &lineage(40, "x")).is_empty());
        assert_eq!(
            differences("learch", &lineage(40, "x"), &lineage(5, "y")),
            [
                "param changed: learch.rounds 40 → 5",
                "input changed: a.parquet"
            ]
        );
    }

    #[test]
    fn lock_files_round_trip_and_missing_ones_are_empty() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.lock");
        assert_eq!(read(&path).unwrap(), LockFile::default());
        let mut lock = LockFile::default();
        lock.stages.insert(
            "learch".into(),
            LockedStage {
                lineage: lineage(3, "x"),
                out: "out/c".into(),
                out_digest: "blake3:00".into(),
            },
        );
        write(&path, &lock).unwrap();
        assert_eq!(read(&path).unwrap(), lock);
        std::fs::write(&path, "{").unwrap();
        assert_eq!(read(&path).unwrap_err().exit_code(), 2);
    }
}
