//! `features`: a dataset's maps in, one feature stack per map out.

use std::path::PathBuf;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{StageParams, StageReport, commit_artifact};
use crate::artifact::{ArtifactBuilder, read_manifest};
use crate::error::{Error, Result, first_error_in_order};
use crate::features::{Bank, DatasetLayers, FeatureSpec, Op, compute_in_dataset};
use crate::io::tables::{read_map, write_features};

pub const KIND: &str = "features";
/// 2: every map gets the no-data indicators of any map in the dataset. 3: slope,
/// aspect and curvature with each row's cell size in geographic frames. 4: the banks'
/// brightness indicators, distances and contrasts, and both banks for elevation
/// layers under `auto`. 5: the imagery bank's gradients (every band's and the
/// brightness's); derivatives step around cells with no data. 8: the banks' per-class
/// indicators on layers of many classes. 9: the roughness of elevation, of a map's
/// only band and of the brightness over windows of 3 to 31 cells. 10: neighbourhoods
/// leave cells without data out. 11: distances and blurs in metres with each row's cell
/// size in geographic frames, and neighbourhoods counted in cells in the cells' mean
/// side on the ground, per axis and row.
const VERSION: u32 = 11;

fn default_bias() -> bool {
    true
}

/// Parameters of `imitate features` and of `uses: features`.
#[derive(Debug, Clone, clap::Args, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeaturesParams {
    /// The dataset folder written by `ingest`.
    #[arg(long, value_name = "DIR")]
    pub dataset: PathBuf,
    /// The features folder to write.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Layers to use as they are, in order (repeat the flag); default: every layer of
    /// each map when no --op is given.
    #[arg(long = "layer", value_name = "NAME")]
    #[serde(default)]
    pub layers: Option<Vec<String>>,
    /// An operator as JSON, e.g. '{"op":"blur","layer":"elevation","sigmas":[1,4]}'
    /// (repeat the flag; schemas/tables/features.md lists them).
    #[arg(long = "op", value_name = "JSON", value_parser = parse_op)]
    #[serde(default)]
    pub ops: Vec<Op>,
    /// Leave out the constant bias feature.
    #[arg(long = "no-bias", action = clap::ArgAction::SetFalse)]
    #[serde(default = "default_bias")]
    pub bias: bool,
    /// Value that no-data (NaN) cells' own values read as (neighbourhood operators leave
    /// such cells out); such layers also get a `/nodata` indicator.
    #[arg(long, default_value_t = 0.0)]
    #[serde(default)]
    pub nodata_fill: f32,
    /// A feature bank: operators chosen by the layers each map has (`imitate` picks
    /// elevation or imagery operators with `auto`; schemas/tables/features.md lists
    /// them), before --layer and --op.
    #[arg(long, value_enum, value_name = "BANK")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bank: Option<Bank>,
}

fn parse_op(text: &str) -> Result<Op, String> {
    serde_json::from_str(text).map_err(|e| format!("not a feature operator: {e}"))
}

impl StageParams for FeaturesParams {
    const KIND: &'static str = KIND;
    const VERSION: u32 = VERSION;

    fn deps(&self) -> Vec<PathBuf> {
        vec![self.dataset.clone()]
    }

    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport> {
        let dataset = read_manifest(&self.dataset, "dataset")?;
        let spec = FeatureSpec {
            layers: self.layers.clone(),
            ops: self.ops.clone(),
            bias: self.bias,
            nodata_fill: self.nodata_fill,
            bank: self.bank,
        };
        let map_files: Vec<PathBuf> = dataset
            .files_with_role("map")
            .map(|f| self.dataset.join(&f.path))
            .collect();
        let maps = first_error_in_order(map_files.par_iter().map(|p| read_map(p)).collect())?;
        let dataset_layers = DatasetLayers::of(&maps);
        if let Some(bank) = spec.bank {
            for hint in bank.class_layer_hints(&dataset_layers, &spec.ops) {
                tracing::warn!("{hint}");
            }
        }
        let progress = super::progress_bar(maps.len(), "feature maps");
        let stacks = maps
            .par_iter()
            .zip(&map_files)
            .map(|(map, path)| {
                let stack = compute_in_dataset(map, &spec, &dataset_layers)
                    .map_err(|e| Error::input(path, e))?;
                progress.inc(1);
                Ok((map.name.clone(), stack))
            })
            .collect::<Vec<_>>();
        progress.finish_and_clear();
        let stacks = first_error_in_order(stacks)?;
        let mut out = ArtifactBuilder::new(&self.out)?;
        let spec_json = serde_json::to_value(&spec).expect("the spec serialises");
        for (name, stack) in &stacks {
            write_features(
                &out.file(&format!("features/{name}.parquet"), "features")?,
                name,
                stack,
                &spec_json,
            )?;
        }
        let names = stacks
            .first()
            .map(|(_, s)| s.names.clone())
            .unwrap_or_default();
        let metrics = serde_json::json!({ "maps": stacks.len(), "features": names });
        let summary = format!(
            "{} maps x {} features ({})",
            stacks.len(),
            names.len(),
            names.join(", ")
        );
        commit_artifact(self, extra_deps, out, "features", metrics, summary)
    }
}
