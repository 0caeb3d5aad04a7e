//! A content-addressed cache of stage outputs in the workspace (`.imitate/cache`):
//! every output a stage makes is kept under its digest, and every stage key points at
//! the output it gave. A stage whose key was seen before (a parameter set back to an
//! earlier value, say) gets its output back by copy instead of running again.

use std::path::{Path, PathBuf};

use crate::artifact::{MANIFEST, Manifest, copy_artifact};
use crate::error::{Error, Result};
use crate::io::fs::write_bytes_atomic;

pub struct OutputCache {
    root: PathBuf,
}

fn hex(digest: &str) -> &str {
    digest.strip_prefix("blake3:").unwrap_or(digest)
}

impl OutputCache {
    /// The cache of the workspace the tool runs in.
    pub fn in_workspace() -> Self {
        OutputCache {
            root: PathBuf::from(".imitate/cache"),
        }
    }

    /// The folders the cache writes into (where leftovers of killed runs may lie).
    pub fn folders(&self) -> [PathBuf; 2] {
        [self.root.join("keys"), self.root.join("outputs")]
    }

    fn key_file(&self, stage_key: &str) -> PathBuf {
        self.root.join("keys").join(hex(stage_key))
    }

    fn output_dir(&self, digest: &str) -> PathBuf {
        self.root.join("outputs").join(hex(digest))
    }

    /// The cached output made under `stage_key`, if it is there and intact.
    pub fn lookup(&self, stage_key: &str) -> Option<(String, PathBuf)> {
        let digest = std::fs::read_to_string(self.key_file(stage_key)).ok()?;
        let dir = self.output_dir(digest.trim());
        let manifest: Manifest =
            serde_json::from_slice(&std::fs::read(dir.join(MANIFEST)).ok()?).ok()?;
        (manifest.digest == digest.trim()).then_some((manifest.digest, dir))
    }

    /// Keeps a copy of `out` (with manifest digest `digest`) made under `stage_key`.
    pub fn store(&self, stage_key: &str, out: &Path, digest: &str) -> Result<()> {
        let dir = self.output_dir(digest);
        if !dir.join(MANIFEST).is_file() {
            copy_artifact(out, &dir)?;
        }
        write_bytes_atomic(&self.key_file(stage_key), digest.as_bytes()).map_err(|e| {
            Error::Failed(format!(
                "recording {} in the output cache: {e}",
                out.display()
            ))
        })
    }

    /// Puts the cached output back at `out`.
    pub fn restore(&self, cached: &Path, out: &Path) -> Result<()> {
        copy_artifact(cached, out)
    }
}

/// One output kept in the cache.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CachedOutput {
    pub digest: String,
    pub kind: String,
    pub bytes: u64,
    /// Stage keys that point at it.
    pub keys: usize,
    /// When a run last stored or restored it (seconds since the Unix epoch).
    pub last_used_unix_s: u64,
}

fn modified_s(path: &Path) -> Option<u64> {
    let modified = std::fs::metadata(path).ok()?.modified().ok()?;
    Some(
        modified
            .duration_since(std::time::UNIX_EPOCH)
            .ok()?
            .as_secs(),
    )
}

fn folder_bytes(dir: &Path) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    entries
        .flatten()
        .map(|e| match e.file_type() {
            Ok(t) if t.is_dir() => folder_bytes(&e.path()),
            _ => e.metadata().map_or(0, |m| m.len()),
        })
        .sum()
}

impl OutputCache {
    /// Every cached output, most recently used first (ties by digest). A run uses an
    /// output when it stores or restores it, which rewrites the key file pointing at it.
    pub fn outputs(&self) -> Result<Vec<CachedOutput>> {
        let mut keys: std::collections::BTreeMap<String, (usize, u64)> = Default::default();
        if let Ok(entries) = std::fs::read_dir(self.root.join("keys")) {
            for entry in entries.flatten() {
                let Ok(digest) = std::fs::read_to_string(entry.path()) else {
                    continue;
                };
                let used = modified_s(&entry.path()).unwrap_or(0);
                let slot = keys.entry(hex(digest.trim()).to_string()).or_default();
                slot.0 += 1;
                slot.1 = slot.1.max(used);
            }
        }
        let mut outputs = Vec::new();
        let Ok(entries) = std::fs::read_dir(self.root.join("outputs")) else {
            return Ok(outputs);
        };
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') || !entry.path().is_dir() {
                continue;
            }
            let manifest: Option<Manifest> = std::fs::read(entry.path().join(MANIFEST))
                .ok()
                .and_then(|b| serde_json::from_slice(&b).ok());
            let (count, used) = keys.get(&name).copied().unwrap_or((0, 0));
            outputs.push(CachedOutput {
                digest: format!("blake3:{name}"),
                kind: manifest.map_or_else(|| "unreadable".into(), |m| m.kind),
                bytes: folder_bytes(&entry.path()),
                keys: count,
                last_used_unix_s: used.max(modified_s(&entry.path()).unwrap_or(0)),
            });
        }
        outputs
            .sort_by(|a, b| (b.last_used_unix_s, &a.digest).cmp(&(a.last_used_unix_s, &b.digest)));
        Ok(outputs)
    }

    /// Removes cached outputs beyond the `keep_last` most recently used, then the least
    /// recently used until the rest fit in `max_bytes`, and every key left pointing at
    /// nothing. Returns what was removed. Only the cache is touched: a workspace's
    /// outputs are separate copies.
    pub fn collect_garbage(
        &self,
        keep_last: Option<usize>,
        max_bytes: Option<u64>,
    ) -> Result<Vec<CachedOutput>> {
        let outputs = self.outputs()?;
        let mut kept_bytes = 0u64;
        let mut removed = Vec::new();
        for (rank, output) in outputs.into_iter().enumerate() {
            let beyond_count = keep_last.is_some_and(|n| rank >= n);
            let beyond_size = max_bytes.is_some_and(|m| kept_bytes + output.bytes > m);
            if beyond_count || beyond_size {
                let dir = self.output_dir(&output.digest);
                std::fs::remove_dir_all(&dir)
                    .map_err(|e| Error::io(format!("removing {}", dir.display()), e))?;
                removed.push(output);
            } else {
                kept_bytes += output.bytes;
            }
        }
        if let Ok(entries) = std::fs::read_dir(self.root.join("keys")) {
            for entry in entries.flatten() {
                let digest = std::fs::read_to_string(entry.path()).unwrap_or_default();
                if !self.output_dir(digest.trim()).join(MANIFEST).is_file() {
                    let _ = std::fs::remove_file(entry.path());
                }
            }
        }
        Ok(removed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn garbage_collection_keeps_the_most_recently_used() {
        let dir = tempfile::tempdir().unwrap();
        let cache = OutputCache {
            root: dir.path().join("cache"),
        };
        let lineage = crate::artifact::Lineage::new("t", 1, serde_json::json!({}), vec![]);
        let mut digests = Vec::new();
        for (i, content) in [&b"one"[..], &[7u8; 5000][..], b"three"].iter().enumerate() {
            let art = dir.path().join(format!("art{i}"));
            let mut b = crate::artifact::ArtifactBuilder::new(&art).unwrap();
            std::fs::write(b.file("x", "data").unwrap(), content).unwrap();
            let m = b
                .commit("thing", lineage.clone(), serde_json::json!({}))
                .unwrap();
            cache
                .store(&format!("blake3:key{i}"), &art, &m.digest)
                .unwrap();
            digests.push(m.digest.clone());
            // Distinct use times, one second apart (file times have whole seconds here).
            let when =
                std::time::SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1000 + i as u64);
            let key = cache.key_file(&format!("blake3:key{i}"));
            std::fs::File::options()
                .write(true)
                .open(&key)
                .unwrap()
                .set_modified(when)
                .unwrap();
            std::fs::File::open(cache.output_dir(&m.digest))
                .unwrap()
                .set_modified(when)
                .unwrap();
        }
        let listed = cache.outputs().unwrap();
        assert_eq!(listed.len(), 3);
        assert_eq!(listed[0].digest, digests[2], "most recent first");
        let removed = cache.collect_garbage(Some(2), None).unwrap();
        assert_eq!(removed.len(), 1);
        assert_eq!(removed[0].digest, digests[0]);
        assert!(cache.lookup("blake3:key0").is_none());
        assert!(
            !cache.key_file("blake3:key0").exists(),
            "its key went with it"
        );
        // The big one does not fit in 2 KB; the newest does.
        let removed = cache.collect_garbage(None, Some(2000)).unwrap();
        assert_eq!(removed.len(), 1);
        assert_eq!(removed[0].digest, digests[1]);
        assert!(cache.lookup("blake3:key2").is_some());
    }
}
