//! `imitate verify`: checks artifacts and DAgger datasets against their manifests, and
//! MCAP files against their chunk CRCs.

use std::path::PathBuf;

use clap::Args;

use crate::artifact::{Verification, verify_folder};
use crate::error::{Error, Result};

#[derive(Args, Debug)]
pub struct VerifyArgs {
    /// Artifact or DAgger dataset folders, or MCAP files.
    #[arg(required = true)]
    pub paths: Vec<PathBuf>,
    /// One JSON object per path.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: VerifyArgs) -> Result<()> {
    let mut damaged: Vec<(PathBuf, usize)> = Vec::new();
    for path in &args.paths {
        let verification = if path.is_dir() {
            if crate::artifact::written_by_imitate(path).as_deref() == Some("dagger-dataset") {
                // Opening finishes an append a kill interrupted after it committed.
                crate::dagger::dataset::Dataset::open(path)?;
            }
            verify_folder(path)?
        } else if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
        {
            verify_log(path)?
        } else {
            return Err(Error::input(
                path,
                "verify checks artifact and DAgger dataset folders, and MCAP files",
            ));
        };
        if args.json {
            outln!(
                "{}",
                serde_json::to_string(&verification).expect("reports serialise")
            );
        } else {
            outln!("{}", render(&verification));
        }
        if let Some(first) = verification.problems.first() {
            damaged.push((path.join(&first.path), verification.problems.len()));
        }
    }
    match damaged.first() {
        None => Ok(()),
        Some((path, count)) => Err(Error::input(
            path,
            format!(
                "is damaged, {count} damaged file(s) in all{}",
                match damaged.len() {
                    1 => String::new(),
                    n => format!(", and {} more damaged path(s)", n - 1),
                }
            ),
        )),
    }
}

/// An MCAP file read from end to end: every chunk decompressed and its CRC checked.
fn verify_log(path: &std::path::Path) -> Result<Verification> {
    let mut chunks = 0usize;
    let mut bytes = 0u64;
    crate::io::mcap::scan(path, |event| {
        if let crate::io::mcap::Event::Chunk { compressed, .. } = event {
            chunks += 1;
            bytes += compressed;
        }
        Ok(())
    })?;
    Ok(Verification {
        folder: path.to_path_buf(),
        kind: "mcap".into(),
        files: chunks,
        bytes,
        problems: Vec::new(),
        unlisted: Vec::new(),
    })
}

fn render(v: &Verification) -> String {
    let unit = if v.kind == "mcap" { "chunks" } else { "files" };
    let mut text = if v.problems.is_empty() {
        format!(
            "{}: ok ({}, {} {unit}, {} bytes)",
            v.folder.display(),
            v.kind,
            v.files,
            v.bytes
        )
    } else {
        format!(
            "{}: DAMAGED ({}, {} of {} files)",
            v.folder.display(),
            v.kind,
            v.problems.len(),
            v.files
        )
    };
    for p in &v.problems {
        text += &format!("\n  {}: {}", p.path, p.problem);
    }
    for u in &v.unlisted {
        text += &format!("\n  {u}: not listed in the manifest (imitate does not read it)");
    }
    text
}
