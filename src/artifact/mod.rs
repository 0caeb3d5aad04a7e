//! Versioned artifacts: folders with a `manifest.json` that names every file with its
//! role and digest, the artifact's own digest and its lineage. Volatile facts (time,
//! duration, threads) go to `run.json`, which is neither listed nor hashed, so that
//! identical inputs give a byte-identical artifact.

mod builder;
mod costs;
mod guard;
mod manifest;
mod verify;

pub use builder::{ArtifactBuilder, copy_artifact};
pub use costs::{References, load_costs};
pub use guard::{check_relative, check_replaceable, written_by_imitate};
pub use manifest::{
    FileEntry, InputDigest, Lineage, MANIFEST, Manifest, RUN_INFO, artifact_digest, digest_input,
    digest_input_with, read_manifest, stage_key,
};
pub use verify::{Problem, Verification, verify_entries, verify_entry, verify_folder};
