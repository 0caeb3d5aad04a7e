//! `imitate export COSTMAP --out DIR`: PNG with a colour bar, GeoTIFF, MCAP for Foxglove.

use std::path::PathBuf;

use crate::error::{Error, Result};
use crate::report::costmap_artifact::CostmapArtifact;
use crate::report::export::{export_geotiff, export_mcap, export_png};

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ExportFormat {
    Png,
    Geotiff,
    Mcap,
}

#[derive(Debug, clap::Args)]
pub struct ExportArgs {
    /// A costmap artifact folder.
    pub costmap: PathBuf,
    /// The folder to write `<map>.png`, `<map>.tif`, `<map>.mcap` into.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Formats to write (repeat; default: all three).
    #[arg(long = "format", value_enum)]
    pub formats: Vec<ExportFormat>,
    /// Only this map (repeat; default: every map of the artifact).
    #[arg(long = "map", value_name = "NAME")]
    pub maps: Vec<String>,
}

pub fn run(args: ExportArgs) -> Result<()> {
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
            };
            result?;
            outln!("{}", path.display());
        }
    }
    Ok(())
}
