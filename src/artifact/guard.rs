//! What an output may replace: only what this tool wrote. A user who names the wrong
//! folder as `--out` (their notes, `src`, `.git`) gets an error before any work, never
//! a deleted folder.

use std::path::{Component, Path};

use super::manifest::{MANIFEST, Manifest};
use crate::error::{Error, Result};

/// The kind of a DAgger dataset's manifest: a store of recorded rounds that cannot be
/// made again, so no artifact ever replaces one.
const DATASET_KIND: &str = "dagger-dataset";

/// Refuses (exit code 2, naming the folder) unless `destination` does not exist, is an
/// empty folder, or is an artifact folder whose manifest says imitate wrote it.
pub fn check_replaceable(destination: &Path) -> Result<()> {
    if destination.file_name().is_none()
        || destination
            .components()
            .next_back()
            .is_some_and(|c| matches!(c, Component::CurDir | Component::ParentDir))
    {
        return Err(Error::Usage(format!(
            "{} cannot be an artifact folder: name a folder of its own",
            shown(destination)
        )));
    }
    let metadata = match std::fs::symlink_metadata(destination) {
        Ok(metadata) => metadata,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => {
            return Err(Error::io(
                format!("checking the output {}", destination.display()),
                e,
            ));
        }
    };
    let refuse = |why: &str| {
        Err(Error::Usage(format!(
            "{}: {why}; imitate replaces only artifact folders it wrote. Name another output, \
             or move it away yourself",
            destination.display()
        )))
    };
    if metadata.file_type().is_symlink() {
        return refuse("is a symbolic link");
    }
    if !metadata.is_dir() {
        return refuse("is a file, not an artifact folder");
    }
    let mut entries = std::fs::read_dir(destination)
        .map_err(|e| Error::io(format!("listing the output {}", destination.display()), e))?;
    if entries.next().is_none() {
        return Ok(());
    }
    match written_by_imitate(destination) {
        Some(kind) if kind == DATASET_KIND => {
            refuse("holds a DAgger dataset, whose rounds cannot be made again")
        }
        Some(_) => Ok(()),
        None => refuse("exists and is not an artifact (it has no imitate manifest.json)"),
    }
}

/// The artifact kind in `dir/manifest.json` when it is a manifest imitate wrote.
pub fn written_by_imitate(dir: &Path) -> Option<String> {
    let bytes = std::fs::read(dir.join(MANIFEST)).ok()?;
    let manifest: Manifest = serde_json::from_slice(&bytes).ok()?;
    manifest
        .schema
        .starts_with("imitate.")
        .then_some(manifest.kind)
}

/// Checks that `relative` (a path inside an artifact, '/'-separated) stays inside it:
/// plain names only, none hidden, no `..`, no root. Names that come from data (map
/// names, episode ids) pass through here before they become files.
pub fn check_relative(relative: &str) -> Result<()> {
    let bad = relative.is_empty()
        || relative.split('/').any(|part| {
            part.is_empty()
                || part.starts_with('.')
                || part.contains('\\')
                || part.chars().any(char::is_control)
        });
    if bad {
        return Err(Error::Usage(format!(
            "'{relative}' cannot name a file inside an artifact (names are plain file names: \
             no '/', '\\', leading '.' or control characters)"
        )));
    }
    Ok(())
}

fn shown(path: &Path) -> String {
    match path.as_os_str().is_empty() {
        true => "an empty path".to_string(),
        false => format!("'{}'", path.display()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replaces_only_what_imitate_wrote() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("new");
        check_replaceable(&missing).unwrap();
        let empty = dir.path().join("empty");
        std::fs::create_dir(&empty).unwrap();
        check_replaceable(&empty).unwrap();

        let notes = dir.path().join("notes");
        std::fs::create_dir(&notes).unwrap();
        std::fs::write(notes.join("todo.txt"), b"keep me").unwrap();
        let err = check_replaceable(&notes).unwrap_err().to_string();
        assert!(
            err.contains("notes") && err.contains("not an artifact"),
            "{err}"
        );

        // A manifest of someone else's is not ours.
        std::fs::write(notes.join(MANIFEST), br#"{"name": "x"}"#).unwrap();
        assert!(check_replaceable(&notes).is_err());

        let file = dir.path().join("file");
        std::fs::write(&file, b"x").unwrap();
        assert!(
            check_replaceable(&file)
                .unwrap_err()
                .to_string()
                .contains("is a file")
        );
        assert!(check_replaceable(Path::new(".")).is_err());
        assert!(check_replaceable(Path::new("a/..")).is_err());
        assert!(check_replaceable(Path::new("")).is_err());
        #[cfg(unix)]
        {
            let link = dir.path().join("link");
            std::os::unix::fs::symlink(&empty, &link).unwrap();
            let err = check_replaceable(&link).unwrap_err().to_string();
            assert!(err.contains("symbolic link"), "{err}");
        }
    }

    #[test]
    fn relative_names_stay_inside() {
        check_relative("maps/terrain-000.parquet").unwrap();
        check_relative("features/Gebiet Süd.parquet").unwrap();
        for bad in [
            "../../../evil.parquet",
            "maps/../x",
            "maps/.hidden",
            "/etc/passwd",
            "a//b",
            "",
            "maps/a\\b",
            "maps/a\nb",
        ] {
            assert!(check_relative(bad).is_err(), "{bad:?} passed");
        }
    }
}
