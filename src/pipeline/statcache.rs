//! A stat cache (`.imitate/stat-cache.json`): the digest of each input file with the
//! size, modification time and inode it had, so that a run in which nothing changed
//! reads metadata instead of hashing file contents.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::io::fs::{file_digest, to_json_bytes, write_bytes_atomic};

/// A file modified this recently may change again within the clock's resolution
/// without its metadata showing it, so its digest is not remembered ("racily clean").
const SETTLED: Duration = Duration::from_secs(2);

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Entry {
    size: u64,
    mtime_ns: u128,
    inode: u64,
    digest: String,
}

#[derive(Debug, Default)]
pub struct StatCache {
    path: PathBuf,
    entries: BTreeMap<String, Entry>,
    changed: bool,
}

fn stamp(meta: &std::fs::Metadata) -> (u64, u128, u64) {
    let mtime = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
        .map_or(0, |d| d.as_nanos());
    #[cfg(unix)]
    let inode = std::os::unix::fs::MetadataExt::ino(meta);
    #[cfg(not(unix))]
    let inode = 0;
    (meta.len(), mtime, inode)
}

impl StatCache {
    /// The workspace's cache; a missing or unreadable one starts empty.
    pub fn in_workspace() -> Self {
        let path = PathBuf::from(".imitate/stat-cache.json");
        let entries = std::fs::read(&path)
            .ok()
            .and_then(|b| serde_json::from_slice(&b).ok())
            .unwrap_or_default();
        StatCache {
            path,
            entries,
            changed: false,
        }
    }

    /// The `blake3:` digest of a file, hashed only when its metadata changed.
    pub fn digest(&mut self, file: &Path) -> Result<String> {
        let meta = std::fs::metadata(file).map_err(|e| Error::input(file, e.to_string()))?;
        let (size, mtime_ns, inode) = stamp(&meta);
        let key = file.to_string_lossy().into_owned();
        if let Some(e) = self
            .entries
            .get(&key)
            .filter(|e| (e.size, e.mtime_ns, e.inode) == (size, mtime_ns, inode))
        {
            return Ok(e.digest.clone());
        }
        let (digest, _) = file_digest(file)?;
        let settled = meta
            .modified()
            .ok()
            .and_then(|t| SystemTime::now().duration_since(t).ok())
            .is_some_and(|age| age > SETTLED);
        if settled {
            self.entries.insert(
                key,
                Entry {
                    size,
                    mtime_ns,
                    inode,
                    digest: digest.clone(),
                },
            );
            self.changed = true;
        }
        Ok(digest)
    }

    pub fn save(&self) -> Result<()> {
        if self.changed {
            write_bytes_atomic(&self.path, &to_json_bytes(&self.entries))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn remembers_settled_files_and_notices_changes() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("f");
        std::fs::write(&file, b"one").unwrap();
        let old = SystemTime::now() - Duration::from_secs(60);
        std::fs::File::options()
            .write(true)
            .open(&file)
            .unwrap()
            .set_modified(old)
            .unwrap();
        let mut cache = StatCache {
            path: dir.path().join("c.json"),
            ..StatCache::default()
        };
        let first = cache.digest(&file).unwrap();
        assert_eq!(first, file_digest(&file).unwrap().0);
        assert!(cache.changed);
        // Same metadata: the remembered digest, even if the bytes were swapped behind
        // the cache's back (which is what a stat cache trusts).
        assert_eq!(cache.digest(&file).unwrap(), first);
        std::fs::write(&file, b"two!").unwrap();
        assert_ne!(
            cache.digest(&file).unwrap(),
            first,
            "size and mtime changed"
        );
        cache.save().unwrap();
        assert!(dir.path().join("c.json").is_file());
    }
}
