//! `export`: a costmap artifact as files other tools open (PNG with a colour bar,
//! GeoTIFF, MCAP for Foxglove, a Nav2 map, its paths as GeoJSON), or a policy artifact as an ONNX model; the
//! files are an artifact of their own, so a pipeline reruns an export only when its
//! costmap or policy changed.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::{StageParams, StageReport, commit_artifact};
use crate::artifact::{ArtifactBuilder, written_by_imitate};
use crate::dagger::onnx::write_policy_model;
use crate::error::{Error, Result};
use crate::report::costmap_artifact::CostmapArtifact;
use crate::report::export::{export_geojson, export_geotiff, export_mcap, export_nav2, export_png};

pub const KIND: &str = "export";
/// 2: the PNG with a labelled colour bar and a scale bar. 3: GeoTIFFs keep the CRS
/// their map was read with.
const VERSION: u32 = 3;

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ExportFormat {
    Png,
    Geotiff,
    Mcap,
    /// A ROS 2 navigation map: `<map>.yaml` and `<map>.pgm` for Nav2's map_server.
    Nav2,
    /// The demonstrations and the plans between their ends as GeoJSON LineStrings in
    /// longitude and latitude (`<map>.geojson`), for QGIS beside the GeoTIFF.
    Geojson,
    /// Policies: `policy.onnx`, for onnxruntime.
    Onnx,
}

/// Parameters of `imitate export` and of `uses: export`.
#[derive(Debug, Clone, clap::Args, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExportParams {
    /// A costmap or policy artifact folder.
    #[serde(rename = "artifact")]
    pub costmap: PathBuf,
    /// The artifact folder to write `<map>.png`, `<map>.tif`, `<map>.mcap`,
    /// `<map>.yaml` + `<map>.pgm`, `<map>.geojson` (or `policy.onnx`) into.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Formats to write (repeat; default: png, geotiff and mcap for a costmap, onnx for
    /// a policy).
    #[arg(long = "format", value_enum)]
    #[serde(default)]
    pub formats: Vec<ExportFormat>,
    /// Only this map (repeat; default: every map of the artifact).
    #[arg(long = "map", value_name = "NAME")]
    #[serde(default)]
    pub maps: Vec<String>,
}

impl StageParams for ExportParams {
    const KIND: &'static str = KIND;
    const VERSION: u32 = VERSION;

    fn deps(&self) -> Vec<PathBuf> {
        vec![self.costmap.clone()]
    }

    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport> {
        let mut out = ArtifactBuilder::new(&self.out)?;
        let files = if written_by_imitate(&self.costmap).as_deref() == Some("policy") {
            self.export_policy(&mut out)?
        } else {
            self.export_costmaps(&mut out)?
        };
        let metrics = serde_json::json!({ "files": files });
        let summary = format!("{} files ({})", files.len(), files.join(", "));
        commit_artifact(self, extra_deps, out, "export", metrics, summary)
    }
}

impl ExportParams {
    fn export_policy(&self, out: &mut ArtifactBuilder) -> Result<Vec<String>> {
        if self.formats.iter().any(|&f| f != ExportFormat::Onnx) {
            return Err(Error::Usage(
                "a policy exports as --format onnx only".into(),
            ));
        }
        write_policy_model(&self.costmap, &out.file("policy.onnx", "model")?)?;
        Ok(vec!["policy.onnx".into()])
    }

    fn export_costmaps(&self, out: &mut ArtifactBuilder) -> Result<Vec<String>> {
        if self.formats.contains(&ExportFormat::Onnx) {
            return Err(Error::Usage(
                "--format onnx exports policy artifacts (from dagger train)".into(),
            ));
        }
        let artifact = CostmapArtifact::load(&self.costmap)?;
        let formats = if self.formats.is_empty() {
            vec![ExportFormat::Png, ExportFormat::Geotiff, ExportFormat::Mcap]
        } else {
            self.formats.clone()
        };
        for wanted in &self.maps {
            if artifact.costmap(wanted).is_none() {
                let names: Vec<&str> = artifact.costmaps.iter().map(|(n, _)| n.as_str()).collect();
                return Err(Error::input(
                    &self.costmap,
                    format!("has no map '{wanted}' (maps: {})", names.join(", ")),
                ));
            }
        }
        let mut written = Vec::new();
        for (name, costs) in &artifact.costmaps {
            if !self.maps.is_empty() && !self.maps.contains(name) {
                continue;
            }
            for format in &formats {
                let file = match format {
                    ExportFormat::Png => {
                        let file = format!("{name}.png");
                        export_png(costs, &out.file(&file, "picture")?)?;
                        file
                    }
                    ExportFormat::Geotiff => {
                        let file = format!("{name}.tif");
                        export_geotiff(costs, &out.file(&file, "raster")?)?;
                        file
                    }
                    ExportFormat::Mcap => {
                        let file = format!("{name}.mcap");
                        export_mcap(&artifact, name, costs, &out.file(&file, "log")?)?;
                        file
                    }
                    ExportFormat::Geojson => {
                        let file = format!("{name}.geojson");
                        export_geojson(&artifact, name, costs, &out.file(&file, "paths")?)?;
                        file
                    }
                    ExportFormat::Nav2 => {
                        out.file(&format!("{name}.pgm"), "map-image")?;
                        let file = format!("{name}.yaml");
                        export_nav2(costs, &out.file(&file, "map")?)?;
                        file
                    }
                    // Refused above: costmaps have no ONNX form.
                    ExportFormat::Onnx => continue,
                };
                written.push(file);
            }
        }
        Ok(written)
    }
}
