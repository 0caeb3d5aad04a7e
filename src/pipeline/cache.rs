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
