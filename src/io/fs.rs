//! Atomic file writes and content digests.

use std::io::{BufWriter, Read, Write};
use std::path::Path;

use tempfile::NamedTempFile;

use crate::error::{Error, Result, open_input};

/// Writes a file atomically: the content goes to a temporary file in the destination
/// folder, is flushed to disk, then renamed over `path`. A crash leaves the old file or
/// the new one, never a half-written one.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut (dyn Write + Send)) -> Result<()>,
) -> Result<()> {
    write_atomic_seekable(path, |out| write(out))
}

/// [`write_atomic`] for writers that seek back (MCAP, whose chunks are patched).
pub fn write_atomic_seekable(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<NamedTempFile>) -> Result<()>,
) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::io(format!("creating {}", dir.display()), e))?;
    // Made and marked as ours while we live (see `leftovers`; released on drop) with
    // no sweep of this process in between.
    let tmp = crate::io::leftovers::claimed(|| {
        let tmp = tempfile::Builder::new()
            .prefix(crate::io::leftovers::TEMPORARY)
            .tempfile_in(dir)?;
        let _ = tmp.as_file().try_lock();
        Ok::<_, std::io::Error>(tmp)
    })
    .map_err(|e| Error::io(format!("creating a temporary file in {}", dir.display()), e))?;
    let mut out = BufWriter::new(tmp);
    write(&mut out)?;
    let tmp = out
        .into_inner()
        .map_err(|e| Error::io(format!("writing {}", path.display()), e.into_error()))?;
    set_public_permissions(tmp.path(), 0o644)?;
    tmp.as_file()
        .sync_all()
        .map_err(|e| Error::io(format!("syncing {}", path.display()), e))?;
    tmp.persist(path)
        .map_err(|e| Error::io(format!("renaming into {}", path.display()), e.error))?;
    Ok(())
}

pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |w| {
        w.write_all(bytes)
            .map_err(|e| Error::io(format!("writing {}", path.display()), e))
    })
}

/// Temporary files and folders are created private (0600/0700); what we publish is
/// readable by others like any file the user writes.
pub fn set_public_permissions(path: &Path, mode: u32) -> Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
            .map_err(|e| Error::io(format!("setting permissions of {}", path.display()), e))?;
    }
    #[cfg(not(unix))]
    let _ = (path, mode);
    Ok(())
}

/// The `blake3:<hex>` digest and size of a file's content.
pub fn file_digest(path: &Path) -> Result<(String, u64)> {
    let mut file = open_input(path)?;
    let mut hasher = blake3::Hasher::new();
    let mut buf = vec![0u8; 1 << 16];
    let mut size = 0u64;
    loop {
        let n = file
            .read(&mut buf)
            .map_err(|e| Error::input(path, e.to_string()))?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
        size += n as u64;
    }
    Ok((format!("blake3:{}", hasher.finalize().to_hex()), size))
}

/// Serialises to pretty JSON with a final newline; keys come out sorted because every
/// map in our JSON values is a BTreeMap.
pub fn to_json_bytes<T: serde::Serialize>(value: &T) -> Vec<u8> {
    let mut bytes = serde_json::to_vec_pretty(value).expect("our types serialise to JSON");
    bytes.push(b'\n');
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporaries() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/out.txt");
        write_bytes_atomic(&path, b"one").unwrap();
        write_bytes_atomic(&path, b"two").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(path.parent().unwrap()).unwrap().collect();
        assert_eq!(names.len(), 1);
        let failed = write_atomic(&path, |_| Err(Error::Failed("boom".into())));
        assert!(failed.is_err());
        assert_eq!(
            std::fs::read(&path).unwrap(),
            b"two",
            "a failed write keeps the old file"
        );
        assert_eq!(
            std::fs::read_dir(path.parent().unwrap()).unwrap().count(),
            1
        );
    }

    #[test]
    fn digest_is_blake3_of_the_content() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        std::fs::write(&path, b"abc").unwrap();
        let (digest, size) = file_digest(&path).unwrap();
        assert_eq!(size, 3);
        assert_eq!(digest, format!("blake3:{}", blake3::hash(b"abc").to_hex()));
    }
}
