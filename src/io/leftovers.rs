//! Leftovers of killed processes. Every staging folder and temporary file imitate makes
//! is held under an advisory lock (`flock`) by the process writing it, for as long as
//! it lives; the kernel drops the lock when the process dies, however it dies. So a
//! leftover that can be locked has no living owner and is swept, and one that cannot
//! belongs to a run still at work and is left alone.

use std::fs::File;
use std::path::Path;

/// Name prefixes of what imitate stages beside its outputs.
pub const STAGING: &str = ".imitate-staging-";
pub const TEMPORARY: &str = ".imitate-tmp-";
pub const RETIRED: &str = ".imitate-retired-";
/// A DAgger round staged inside the dataset's `data/` folder.
pub const ROUND: &str = ".round-";

/// Held while a staging folder or temporary file is created and locked, and while a
/// sweep runs: without it, a sweep on another thread of this process (stages of one
/// pipeline run side by side, their outputs in one folder) could take a new folder in
/// the instant between its creation and its lock, and remove it.
static CLAIMS: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Runs `create_and_hold`, which makes something a sweep would match and locks it, so
/// that no sweep of this process runs in between.
pub fn claimed<T>(create_and_hold: impl FnOnce() -> T) -> T {
    let _claims = CLAIMS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    create_and_hold()
}

/// Takes the lock that marks `path` (a folder or file) as in use by this process; the
/// lock lasts as long as the returned handle. `None` where the platform cannot lock it
/// (then it is never swept while in use, since sweeping needs the lock too).
pub fn hold(path: &Path) -> Option<File> {
    let file = File::open(path).ok()?;
    file.try_lock().ok()?;
    Some(file)
}

/// Removes the entries of `dir` whose names start with one of `prefixes` and that no
/// living process holds. Returns how many were removed; what cannot be removed stays.
pub fn sweep(dir: &Path, prefixes: &[&str]) -> usize {
    let _claims = CLAIMS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if !prefixes.iter().any(|p| name.starts_with(p)) {
            continue;
        }
        let path = entry.path();
        // Held by us while we remove it, so no process can take it up meanwhile.
        let Some(_held) = hold(&path) else { continue };
        let gone = match entry.file_type() {
            Ok(t) if t.is_dir() => std::fs::remove_dir_all(&path),
            _ => std::fs::remove_file(&path),
        };
        if gone.is_ok() {
            tracing::info!(path = %path.display(), "removed the leftover of a killed run");
            removed += 1;
        }
    }
    removed
}

/// What `sweep` removes beside artifact outputs.
pub const BESIDE_OUTPUTS: [&str; 3] = [STAGING, TEMPORARY, RETIRED];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweeps_what_no_process_holds_and_keeps_the_rest() {
        let dir = tempfile::tempdir().unwrap();
        let dead = dir.path().join(".imitate-staging-dead");
        std::fs::create_dir_all(dead.join("sub")).unwrap();
        std::fs::write(dead.join("sub/x"), b"x").unwrap();
        let live = dir.path().join(".imitate-staging-live");
        std::fs::create_dir(&live).unwrap();
        let _owner = hold(&live).expect("folders can be locked here");
        let tmp = dir.path().join(".imitate-tmp-abc");
        std::fs::write(&tmp, b"half").unwrap();
        let user = dir.path().join("notes.txt");
        std::fs::write(&user, b"mine").unwrap();

        assert_eq!(sweep(dir.path(), &BESIDE_OUTPUTS), 2);
        assert!(!dead.exists() && !tmp.exists());
        assert!(live.exists(), "a living run's staging folder stays");
        assert!(user.exists());
    }

    #[test]
    fn a_sweep_on_another_thread_never_takes_a_folder_being_claimed() {
        let dir = tempfile::tempdir().unwrap();
        let parent = dir.path().to_path_buf();
        let done = std::sync::atomic::AtomicBool::new(false);
        let swept = std::thread::scope(|scope| {
            scope.spawn(|| {
                while !done.load(std::sync::atomic::Ordering::Relaxed) {
                    sweep(&parent, &BESIDE_OUTPUTS);
                }
            });
            let swept = (0..50)
                .filter(|_| {
                    let (staging, _held) = claimed(|| {
                        let staging = tempfile::Builder::new()
                            .prefix(STAGING)
                            .tempdir_in(&parent)
                            .unwrap();
                        // A slow moment between creation and lock: without the claim,
                        // the sweeping thread takes the folder here.
                        std::thread::sleep(std::time::Duration::from_millis(2));
                        let held = hold(staging.path());
                        (staging, held)
                    });
                    !staging.path().is_dir()
                })
                .count();
            done.store(true, std::sync::atomic::Ordering::Relaxed);
            swept
        });
        assert_eq!(swept, 0, "claimed folders were swept");
    }
}
