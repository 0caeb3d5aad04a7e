//! `imitate export COSTMAP --out DIR`: PNG with a colour bar, GeoTIFF, MCAP for Foxglove,
//! a Nav2 map (YAML and PGM);
//! `imitate export POLICY --out DIR`: the policy as an ONNX model.

use std::path::PathBuf;

use crate::artifact::written_by_imitate;
use crate::dagger::onnx::write_policy_model;
use crate::error::{Error, Result};
use crate::report::costmap_artifact::CostmapArtifact;
use crate::report::export::{export_geotiff, export_mcap, export_nav2, export_png};

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ExportFormat {
    Png,
    Geotiff,
    Mcap,
    /// A ROS 2 navigation map: `<map>.yaml` and `<map>.pgm` for Nav2's map_server.
    Nav2,
    /// Policies: `policy.onnx`, for onnxruntime.
    Onnx,
}

#[derive(Debug, clap::Args)]
pub struct ExportArgs {
    /// A costmap or policy artifact folder.
    pub costmap: PathBuf,
    /// The folder to write `<map>.png`, `<map>.tif`, `<map>.mcap` (or `policy.onnx`)
    /// into.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Formats to write (repeat; default: png, geotiff and mcap).
    #[arg(long = "format", value_enum)]
    pub formats: Vec<ExportFormat>,
    /// Only this map (repeat; default: every map of the artifact).
    #[arg(long = "map", value_name = "NAME")]
    pub maps: Vec<String>,
}

pub fn run(args: ExportArgs) -> Result<()> {
    if written_by_imitate(&args.costmap).as_deref() == Some("policy") {
        if args.formats.iter().any(|&f| f != ExportFormat::Onnx) {
            return Err(Error::Usage(
                "a policy exports as --format onnx only".into(),
            ));
        }
        std::fs::create_dir_all(&args.out)
            .map_err(|e| Error::io(format!("creating {}", args.out.display()), e))?;
        let path = args.out.join("policy.onnx");
        write_policy_model(&args.costmap, &path)?;
        outln!("{}", path.display());
        return Ok(());
    }
    if args.formats.contains(&ExportFormat::Onnx) {
        return Err(Error::Usage(
            "--format onnx exports policy artifacts (from dagger train)".into(),
        ));
    }
    let artifact = CostmapArtifact::load(&args.costmap)?;
    let formats = if args.formats.is_empty() {
        vec![ExportFormat::Png, ExportFormat::Geotiff, ExportFormat::Mcap]
    } else {
        args.formats.clone()
    };
    for wanted in &args.maps {
        if artifact.costmap(wanted).is_none() {
            let names: Vec<&str> = artifact.costmaps.iter().map(|(n, _)| n.as_str()).collect();
            return Err(Error::input(
                &args.costmap,
                format!("has no map '{wanted}' (maps: {})", names.join(", ")),
            ));
        }
    }
    for (name, costs) in &artifact.costmaps {
        if !args.maps.is_empty() && !args.maps.contains(name) {
            continue;
        }
        for format in &formats {
            let (path, result) = match format {
                ExportFormat::Png => {
                    let path = args.out.join(format!("{name}.png"));
                    let result = export_png(costs, &path);
                    (path, result)
                }
                ExportFormat::Geotiff => {
                    let path = args.out.join(format!("{name}.tif"));
                    let result = export_geotiff(costs, &path);
                    (path, result)
                }
                ExportFormat::Mcap => {
                    let path = args.out.join(format!("{name}.mcap"));
                    let result = export_mcap(&artifact, name, costs, &path);
                    (path, result)
                }
                ExportFormat::Nav2 => {
                    let path = args.out.join(format!("{name}.yaml"));
                    let result = export_nav2(costs, &path);
                    (path, result)
                }
                // Refused above: costmaps have no ONNX form.
                ExportFormat::Onnx => continue,
            };
            result?;
            outln!("{}", path.display());
        }
    }
    Ok(())
}
