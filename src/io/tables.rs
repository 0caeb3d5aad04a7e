//! The Parquet tables the tool reads and writes (arrow-rs). Every file carries
//! `imitate.schema = "<table>/<major>"` in its key-value metadata; readers refuse other
//! tables and unknown major versions. Descriptions live in `schemas/tables/`.
//!
//! Rasters (maps, feature stacks, costmaps) share one layout: one row per cell, row by
//! row, with `row` and `col` columns followed by one f32 column per layer, and the
//! georeference as JSON under `imitate.raster`.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use arrow::array::{
    Array, ArrayRef, AsArray, Float32Array, Float64Array, RecordBatch, StringArray, UInt32Array,
};
use arrow::datatypes::{DataType, Field, Schema, UInt32Type};
use parquet::arrow::ArrowWriter;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::basic::Compression;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use serde::{Deserialize, Serialize};

use super::fs::write_atomic;
use crate::error::{Error, Result, guard_decoder, read_input};
use crate::grid::{CellPath, Demonstration, FeatureStack, GeoRef, Grid, Layer, LayerKind, Map};

pub const SCHEMA_KEY: &str = "imitate.schema";
const RASTER_KEY: &str = "imitate.raster";
const FEATURE_SPEC_KEY: &str = "imitate.feature_spec";

/// A table's name and the major version of its layout this build reads and writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Table {
    pub name: &'static str,
    pub major: u32,
}

impl Table {
    pub const MAP: Table = Table {
        name: "map",
        major: 1,
    };
    pub const FEATURES: Table = Table {
        name: "features",
        major: 1,
    };
    pub const COSTMAP: Table = Table {
        name: "costmap",
        major: 1,
    };
    pub const DEMONSTRATIONS: Table = Table {
        name: "demonstrations",
        major: 1,
    };
    pub const PATHS: Table = Table {
        name: "paths",
        major: 1,
    };

    /// `imitate bench objectworld --export`: a world's states (x, y, features, true reward).
    pub const OBJECTWORLD: Table = Table {
        name: "objectworld",
        major: 1,
    };
    /// A reward learned on a tabular MDP, per state, with its optimal policy's action.
    pub const LEARNED_REWARD: Table = Table {
        name: "learned-reward",
        major: 1,
    };
    /// One row per control step of a DAgger dataset round.
    pub const DAGGER_STEPS: Table = Table {
        name: "dagger-steps",
        major: 1,
    };
    /// One row per round of a DAgger dataset.
    pub const DAGGER_ROUNDS: Table = Table {
        name: "dagger-rounds",
        major: 1,
    };
    /// A forecast's expected visits per cell (`imitate forecast`).
    pub const FORECAST_VISITATION: Table = Table {
        name: "forecast-visitation",
        major: 1,
    };
    /// A forecast's posterior over candidate destinations.
    pub const FORECAST_DESTINATIONS: Table = Table {
        name: "forecast-destinations",
        major: 1,
    };

    pub fn tag(&self) -> String {
        format!("{}/{}", self.name, self.major)
    }
}

impl std::fmt::Display for Table {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.name, self.major)
    }
}

/// Checks a file's `imitate.schema` tag against the table expected. A missing tag is
/// accepted only where `allow_untagged` (tables people write with pandas or polars).
fn check_schema_tag(
    path: &Path,
    tag: Option<&str>,
    table: Table,
    allow_untagged: bool,
) -> Result<()> {
    let Some(tag) = tag else {
        if allow_untagged {
            return Ok(());
        }
        return Err(Error::input(
            path,
            format!(
                "has no '{SCHEMA_KEY}' metadata: expected a '{table}' table written by imitate"
            ),
        ));
    };
    let (name, major) = tag.split_once('/').unwrap_or((tag, ""));
    if name != table.name {
        return Err(Error::input(
            path,
            format!("{SCHEMA_KEY} is '{tag}', expected a '{table}' table"),
        ));
    }
    if major.parse::<u32>().ok() != Some(table.major) {
        return Err(Error::input(
            path,
            format!(
                "{SCHEMA_KEY} is '{tag}': this imitate ({}) reads '{table}' only; \
                 a newer version may have written it",
                env!("CARGO_PKG_VERSION")
            ),
        ));
    }
    Ok(())
}

pub(crate) fn write_table(
    path: &Path,
    table: Table,
    batch: &RecordBatch,
    mut metadata: Vec<(String, String)>,
) -> Result<()> {
    metadata.push((SCHEMA_KEY.to_string(), table.tag()));
    metadata.sort();
    let props = WriterProperties::builder()
        .set_compression(Compression::SNAPPY)
        .set_created_by(format!("imitate {}", env!("CARGO_PKG_VERSION")))
        .set_key_value_metadata(Some(
            metadata
                .into_iter()
                .map(|(k, v)| KeyValue::new(k, v))
                .collect(),
        ))
        .build();
    let what = |e: parquet::errors::ParquetError| {
        Error::Failed(format!("writing {}: {e}", path.display()))
    };
    write_atomic(path, |out| {
        let mut writer = ArrowWriter::try_new(out, batch.schema(), Some(props)).map_err(what)?;
        writer.write(batch).map_err(what)?;
        writer.close().map_err(what)?;
        Ok(())
    })
}

/// Writes columns of f64 numbers as a tagged table.
pub fn write_numeric_table(path: &Path, table: Table, columns: &[(&str, &[f64])]) -> Result<()> {
    let fields: Vec<Field> = columns
        .iter()
        .map(|(name, _)| Field::new(*name, DataType::Float64, false))
        .collect();
    let arrays: Vec<ArrayRef> = columns
        .iter()
        .map(|(_, values)| Arc::new(Float64Array::from(values.to_vec())) as ArrayRef)
        .collect();
    let batch = RecordBatch::try_new(Arc::new(Schema::new(fields)), arrays)
        .map_err(|e| Error::Failed(format!("building {}: {e}", path.display())))?;
    write_table(path, table, &batch, Vec::new())
}

/// Reads the named f64 columns of a table written by [`write_numeric_table`].
pub fn read_numeric_table(path: &Path, table: Table, columns: &[&str]) -> Result<Vec<Vec<f64>>> {
    let batch = read_table(path, table, false)?.batch;
    columns
        .iter()
        .map(|name| {
            let array = column(path, table, &batch, name)?;
            no_nulls(path, name, array.as_ref())?;
            let values = array
                .as_primitive_opt::<arrow::datatypes::Float64Type>()
                .ok_or_else(|| Error::input(path, format!("column '{name}' is not float64")))?;
            Ok(values.values().to_vec())
        })
        .collect()
}

/// A table read back: its key-value metadata and its rows as one batch.
pub(crate) struct ReadTable {
    pub(crate) metadata: BTreeMap<String, String>,
    pub(crate) batch: RecordBatch,
}

pub(crate) fn read_table(path: &Path, table: Table, allow_untagged: bool) -> Result<ReadTable> {
    // In memory: a table is read whole anyway, and the page reader then never makes a
    // system call per byte of a damaged page header (a 2.6 KB file took 53 s from disk).
    let bytes = bytes::Bytes::from(read_input(path)?);
    guard_decoder(path, &format!("reading a '{table}' table"), || {
        decode_table(path, bytes, table, allow_untagged)
    })
}

fn decode_table(
    path: &Path,
    bytes: bytes::Bytes,
    table: Table,
    allow_untagged: bool,
) -> Result<ReadTable> {
    super::parquet_check::check_footer(&bytes)
        .map_err(|e| Error::input(path, format!("not a readable Parquet file: {e}")))?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(bytes.clone())
        .map_err(|e| Error::input(path, format!("not a readable Parquet file: {e}")))?;
    check_layout(path, builder.metadata(), &bytes)?;
    let metadata: BTreeMap<String, String> = builder
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .into_iter()
        .flatten()
        .filter_map(|kv| kv.value.clone().map(|v| (kv.key.clone(), v)))
        .collect();
    check_schema_tag(
        path,
        metadata.get(SCHEMA_KEY).map(String::as_str),
        table,
        allow_untagged,
    )?;
    let schema = builder.schema().clone();
    let reader = builder
        .build()
        .map_err(|e| Error::input(path, format!("cannot read '{table}' rows: {e}")))?;
    let batches = reader
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(|e| Error::input(path, format!("cannot read '{table}' rows: {e}")))?;
    let batch = arrow::compute::concat_batches(&schema, &batches)
        .map_err(|e| Error::input(path, format!("cannot read '{table}' rows: {e}")))?;
    Ok(ReadTable { metadata, batch })
}

/// Checks that every column chunk the footer describes lies inside the file, and that
/// its pages fit in it and in the memory budget ([`super::parquet_check`]), before the
/// reader seeks to it: the `parquet` crate asserts (panics) on negative offsets and
/// lengths, which a damaged footer can hold, and allocates what page headers claim.
fn check_layout(
    path: &Path,
    metadata: &parquet::file::metadata::ParquetMetaData,
    file: &[u8],
) -> Result<()> {
    let file_len = file.len() as u64;
    for (g, group) in metadata.row_groups().iter().enumerate() {
        if group.num_rows() < 0 {
            return Err(Error::input(
                path,
                format!(
                    "row group {g} claims {} rows: the file is damaged",
                    group.num_rows()
                ),
            ));
        }
        for (c, column) in group.columns().iter().enumerate() {
            let start = column
                .dictionary_page_offset()
                .unwrap_or(column.data_page_offset());
            let inside = start >= 0
                && column.data_page_offset() >= 0
                && column.compressed_size() >= 0
                && column.num_values() >= 0
                && (start as u64).saturating_add(column.compressed_size() as u64) <= file_len;
            if !inside {
                return Err(Error::input(
                    path,
                    format!(
                        "row group {g}, column {c} ({}): its pages (offset {start}, {} bytes) \
                         are not inside the file of {file_len} bytes: the file is damaged",
                        column.column_path(),
                        column.compressed_size()
                    ),
                ));
            }
            let pages = &file[start as usize..(start + column.compressed_size()) as usize];
            super::parquet_check::check_pages(pages, column.compression()).map_err(|e| {
                Error::input(
                    path,
                    format!(
                        "row group {g}, column {c} ({}): {e}: the file is damaged",
                        column.column_path()
                    ),
                )
            })?;
        }
    }
    Ok(())
}

/// Finds a column by name, with an error naming the file and the table when absent.
fn column<'a>(
    path: &Path,
    table: Table,
    batch: &'a RecordBatch,
    name: &str,
) -> Result<&'a ArrayRef> {
    batch
        .column_by_name(name)
        .ok_or_else(|| Error::input(path, format!("'{table}' table has no column '{name}'")))
}

fn no_nulls(path: &Path, name: &str, array: &dyn Array) -> Result<()> {
    if array.null_count() == 0 {
        return Ok(());
    }
    let record = (0..array.len()).find(|&i| array.is_null(i)).unwrap_or(0);
    Err(Error::input(
        path,
        format!("record {record}: column '{name}' is null"),
    ))
}

fn u32_column<'a>(
    path: &Path,
    table: Table,
    batch: &'a RecordBatch,
    name: &str,
) -> Result<&'a UInt32Array> {
    let array = column(path, table, batch, name)?;
    no_nulls(path, name, array.as_ref())?;
    array.as_primitive_opt::<UInt32Type>().ok_or_else(|| {
        Error::input(
            path,
            format!(
                "column '{name}' has type {}, expected UInt32",
                array.data_type()
            ),
        )
    })
}

/// Text column as owned strings (Utf8, LargeUtf8 and Utf8View are all accepted).
fn string_column(
    path: &Path,
    table: Table,
    batch: &RecordBatch,
    name: &str,
) -> Result<Vec<String>> {
    let array = column(path, table, batch, name)?;
    no_nulls(path, name, array.as_ref())?;
    let cast = match array.data_type() {
        DataType::Utf8 | DataType::LargeUtf8 | DataType::Utf8View => {
            arrow::compute::cast(array, &DataType::Utf8)
                .map_err(|e| Error::input(path, format!("column '{name}': {e}")))?
        }
        other => {
            return Err(Error::input(
                path,
                format!("column '{name}' has type {other}, expected text"),
            ));
        }
    };
    Ok(cast
        .as_string::<i32>()
        .iter()
        .map(|s| s.unwrap_or_default().to_string())
        .collect())
}

// ---------------------------------------------------------------------------------
// Rasters

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RasterHeader {
    name: String,
    geo: GeoRef,
}

/// A raster table read back: its name, georeference and named f32 columns.
#[derive(Debug, Clone)]
pub struct Raster {
    pub name: String,
    pub geo: GeoRef,
    pub columns: Vec<(String, Vec<f32>)>,
    metadata: BTreeMap<String, String>,
}

fn write_raster(
    path: &Path,
    table: Table,
    name: &str,
    geo: &GeoRef,
    columns: Vec<(String, Vec<f32>)>,
    mut metadata: Vec<(String, String)>,
) -> Result<()> {
    let n = geo.cell_count();
    let width = geo.width;
    let mut fields = vec![
        Field::new("row", DataType::UInt32, false),
        Field::new("col", DataType::UInt32, false),
    ];
    let mut arrays: Vec<ArrayRef> = vec![
        Arc::new(UInt32Array::from_iter_values(
            (0..n as u32).map(|i| i / width),
        )),
        Arc::new(UInt32Array::from_iter_values(
            (0..n as u32).map(|i| i % width),
        )),
    ];
    for (column_name, values) in columns {
        debug_assert_eq!(values.len(), n);
        fields.push(Field::new(column_name, DataType::Float32, false));
        arrays.push(Arc::new(Float32Array::from(values)));
    }
    let batch = RecordBatch::try_new(Arc::new(Schema::new(fields)), arrays)
        .map_err(|e| Error::Failed(format!("building {}: {e}", path.display())))?;
    let header = RasterHeader {
        name: name.to_string(),
        geo: geo.clone(),
    };
    metadata.push((
        RASTER_KEY.into(),
        serde_json::to_string(&header).expect("header serialises"),
    ));
    write_table(path, table, &batch, metadata)
}

fn read_raster(path: &Path, table: Table) -> Result<Raster> {
    let ReadTable { metadata, batch } = read_table(path, table, false)?;
    let header: RasterHeader = metadata
        .get(RASTER_KEY)
        .ok_or_else(|| {
            Error::input(
                path,
                format!("'{table}' table has no '{RASTER_KEY}' metadata"),
            )
        })
        .and_then(|json| {
            serde_json::from_str(json)
                .map_err(|e| Error::input(path, format!("'{RASTER_KEY}' metadata: {e}")))
        })?;
    header
        .geo
        .validate()
        .map_err(|e| Error::input(path, format!("'{RASTER_KEY}' metadata: {e}")))?;
    let geo = header.geo;
    let n = geo.cell_count();
    if batch.num_rows() != n {
        return Err(Error::input(
            path,
            format!(
                "has {} rows, but a {}x{} raster needs {n}",
                batch.num_rows(),
                geo.width,
                geo.height
            ),
        ));
    }
    let rows = u32_column(path, table, &batch, "row")?;
    let cols = u32_column(path, table, &batch, "col")?;
    for i in 0..n {
        let expected = geo.cell_at(i);
        if rows.value(i) != expected.row || cols.value(i) != expected.col {
            return Err(Error::input(
                path,
                format!(
                    "record {i}: cell (row {}, col {}) where {expected} was expected; \
                     raster tables list cells row by row",
                    rows.value(i),
                    cols.value(i)
                ),
            ));
        }
    }
    let mut columns = Vec::new();
    for (field, array) in batch.schema().fields().iter().zip(batch.columns()) {
        if field.name() == "row" || field.name() == "col" {
            continue;
        }
        no_nulls(path, field.name(), array.as_ref())?;
        let values = array
            .as_primitive_opt::<arrow::datatypes::Float32Type>()
            .ok_or_else(|| {
                Error::input(
                    path,
                    format!(
                        "column '{}' has type {}, expected Float32",
                        field.name(),
                        field.data_type()
                    ),
                )
            })?;
        columns.push((field.name().clone(), values.values().to_vec()));
    }
    Ok(Raster {
        name: header.name,
        geo,
        columns,
        metadata,
    })
}

/// The names of a map's layers declared as classes ([`LayerKind::Classes`]), a JSON
/// list; absent where there are none.
const CLASS_LAYERS_KEY: &str = "imitate.class_layers";

pub fn write_map(path: &Path, map: &Map) -> Result<()> {
    let columns = map
        .layers
        .iter()
        .map(|l| (l.name.clone(), l.values.clone()))
        .collect();
    let class_layers: Vec<&str> = map
        .layers
        .iter()
        .filter(|l| l.kind == LayerKind::Classes)
        .map(|l| l.name.as_str())
        .collect();
    let metadata = if class_layers.is_empty() {
        Vec::new()
    } else {
        let names = serde_json::to_string(&class_layers).expect("names serialise");
        vec![(CLASS_LAYERS_KEY.to_string(), names)]
    };
    write_raster(path, Table::MAP, &map.name, &map.geo, columns, metadata)
}

pub fn read_map(path: &Path) -> Result<Map> {
    let raster = read_raster(path, Table::MAP)?;
    if raster.columns.is_empty() {
        return Err(Error::input(path, "map has no layers"));
    }
    let class_layers: Vec<String> = match raster.metadata.get(CLASS_LAYERS_KEY) {
        None => Vec::new(),
        Some(json) => serde_json::from_str(json)
            .map_err(|e| Error::input(path, format!("'{CLASS_LAYERS_KEY}' metadata: {e}")))?,
    };
    let layers = raster
        .columns
        .into_iter()
        .map(|(name, values)| {
            let layer = Layer::new(name, values);
            if class_layers.contains(&layer.name) {
                layer.declared_classes()
            } else {
                layer
            }
        })
        .collect();
    Ok(Map {
        name: raster.name,
        geo: raster.geo,
        layers,
    })
}

/// Writes a feature stack; `spec` is the JSON of the feature spec that made it.
pub fn write_features(
    path: &Path,
    name: &str,
    stack: &FeatureStack,
    spec: &serde_json::Value,
) -> Result<()> {
    let columns = stack
        .names
        .iter()
        .cloned()
        .zip(stack.planes().map(<[f32]>::to_vec))
        .collect();
    let spec = (FEATURE_SPEC_KEY.to_string(), spec.to_string());
    write_raster(path, Table::FEATURES, name, &stack.geo, columns, vec![spec])
}

/// Reads a feature stack with its map name and the spec that made it.
/// The map name and georeference of a features table, from its footer alone: what a
/// worker that loads only some maps' features needs to know of the others.
pub fn read_features_header(path: &Path) -> Result<(String, GeoRef)> {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let file = std::fs::File::open(path)
        .map_err(|e| Error::io(format!("reading {}", path.display()), e))?;
    let reader = guard_decoder(path, "reading a features table's footer", || {
        SerializedFileReader::new(file)
            .map_err(|e| Error::input(path, format!("not a readable Parquet file: {e}")))
    })?;
    let header = reader
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .into_iter()
        .flatten()
        .find(|kv| kv.key == RASTER_KEY)
        .and_then(|kv| kv.value.clone())
        .ok_or_else(|| {
            Error::input(
                path,
                format!("'{}' table has no '{RASTER_KEY}' metadata", Table::FEATURES),
            )
        })?;
    let header: RasterHeader = serde_json::from_str(&header)
        .map_err(|e| Error::input(path, format!("'{RASTER_KEY}' metadata: {e}")))?;
    header
        .geo
        .validate()
        .map_err(|e| Error::input(path, format!("'{RASTER_KEY}' metadata: {e}")))?;
    Ok((header.name, header.geo))
}

pub fn read_features(path: &Path) -> Result<(String, FeatureStack, serde_json::Value)> {
    let raster = read_raster(path, Table::FEATURES)?;
    let spec = raster
        .metadata
        .get(FEATURE_SPEC_KEY)
        .and_then(|s| serde_json::from_str(s).ok())
        .ok_or_else(|| {
            Error::input(
                path,
                format!("features table has no valid '{FEATURE_SPEC_KEY}'"),
            )
        })?;
    let n = raster.geo.cell_count();
    let names: Vec<String> = raster.columns.iter().map(|(n, _)| n.clone()).collect();
    if names.is_empty() {
        return Err(Error::input(path, "features table has no feature columns"));
    }
    let mut data = Vec::with_capacity(n * names.len());
    for (_, values) in &raster.columns {
        data.extend_from_slice(values);
    }
    Ok((
        raster.name,
        FeatureStack {
            geo: raster.geo,
            names,
            data,
        },
        spec,
    ))
}

pub fn write_costmap(path: &Path, name: &str, costs: &Grid<f32>) -> Result<()> {
    write_raster(
        path,
        Table::COSTMAP,
        name,
        &costs.geo,
        vec![("cost".into(), costs.data.clone())],
        Vec::new(),
    )
}

pub fn read_costmap(path: &Path) -> Result<(String, Grid<f32>)> {
    let raster = read_raster(path, Table::COSTMAP)?;
    let (_, cost) = raster
        .columns
        .into_iter()
        .find(|(n, _)| n == "cost")
        .ok_or_else(|| Error::input(path, "costmap table has no column 'cost'"))?;
    if let Some(i) = cost.iter().position(|c| c.is_nan() || *c < 0.0) {
        return Err(Error::input(
            path,
            format!("record {i}: cost {} is not a non-negative number", cost[i]),
        ));
    }
    Ok((raster.name, Grid::from_vec(raster.geo, cost)))
}

// ---------------------------------------------------------------------------------
// Demonstrations and cell paths

pub fn write_demonstrations(path: &Path, demos: &[Demonstration]) -> Result<()> {
    let rows = demos
        .iter()
        .flat_map(|d| d.poses.iter().map(move |p| (d, p)));
    let episode: StringArray = rows
        .clone()
        .map(|(d, _)| Some(d.episode.as_str()))
        .collect();
    let map: StringArray = rows.clone().map(|(d, _)| Some(d.map.as_str())).collect();
    let t: Float64Array = rows.clone().map(|(_, p)| Some(p.t)).collect();
    let x: Float64Array = rows.clone().map(|(_, p)| Some(p.x)).collect();
    let y: Float64Array = rows.clone().map(|(_, p)| Some(p.y)).collect();
    let yaw: Float64Array = rows.map(|(_, p)| p.yaw).collect();
    let schema = Schema::new(vec![
        Field::new("episode", DataType::Utf8, false),
        Field::new("map", DataType::Utf8, false),
        Field::new("t", DataType::Float64, false),
        Field::new("x", DataType::Float64, false),
        Field::new("y", DataType::Float64, false),
        Field::new("yaw", DataType::Float64, true),
    ]);
    let arrays: Vec<ArrayRef> = vec![
        Arc::new(episode),
        Arc::new(map),
        Arc::new(t),
        Arc::new(x),
        Arc::new(y),
        Arc::new(yaw),
    ];
    let batch = RecordBatch::try_new(Arc::new(schema), arrays)
        .map_err(|e| Error::Failed(format!("building {}: {e}", path.display())))?;
    write_table(path, Table::DEMONSTRATIONS, &batch, Vec::new())
}

/// A demonstration rasterised onto its map.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodePath {
    pub episode: String,
    pub map: String,
    pub cells: CellPath,
}

pub fn write_paths(path: &Path, paths: &[EpisodePath]) -> Result<()> {
    let rows = paths
        .iter()
        .flat_map(|p| p.cells.iter().enumerate().map(move |(k, c)| (p, k, c)));
    let episode: StringArray = rows
        .clone()
        .map(|(p, _, _)| Some(p.episode.as_str()))
        .collect();
    let map: StringArray = rows.clone().map(|(p, _, _)| Some(p.map.as_str())).collect();
    let step = UInt32Array::from_iter_values(rows.clone().map(|(_, k, _)| k as u32));
    let row = UInt32Array::from_iter_values(rows.clone().map(|(_, _, c)| c.row));
    let col = UInt32Array::from_iter_values(rows.map(|(_, _, c)| c.col));
    let schema = Schema::new(vec![
        Field::new("episode", DataType::Utf8, false),
        Field::new("map", DataType::Utf8, false),
        Field::new("step", DataType::UInt32, false),
        Field::new("row", DataType::UInt32, false),
        Field::new("col", DataType::UInt32, false),
    ]);
    let arrays: Vec<ArrayRef> = vec![
        Arc::new(episode),
        Arc::new(map),
        Arc::new(step),
        Arc::new(row),
        Arc::new(col),
    ];
    let batch = RecordBatch::try_new(Arc::new(schema), arrays)
        .map_err(|e| Error::Failed(format!("building {}: {e}", path.display())))?;
    write_table(path, Table::PATHS, &batch, Vec::new())
}

pub fn read_paths(path: &Path) -> Result<Vec<EpisodePath>> {
    let table = Table::PATHS;
    let ReadTable { batch, .. } = read_table(path, table, false)?;
    let episodes = string_column(path, table, &batch, "episode")?;
    let maps = string_column(path, table, &batch, "map")?;
    let steps = u32_column(path, table, &batch, "step")?;
    let rows = u32_column(path, table, &batch, "row")?;
    let cols = u32_column(path, table, &batch, "col")?;
    let mut paths: Vec<EpisodePath> = Vec::new();
    for i in 0..batch.num_rows() {
        let cell = crate::grid::Cell::new(rows.value(i), cols.value(i));
        match paths.last_mut() {
            Some(p) if p.episode == episodes[i] && steps.value(i) as usize == p.cells.len() => {
                p.cells.push(cell)
            }
            _ if steps.value(i) == 0 => paths.push(EpisodePath {
                episode: episodes[i].clone(),
                map: maps[i].clone(),
                cells: vec![cell],
            }),
            _ => {
                return Err(Error::input(
                    path,
                    format!("record {i}: step {} out of sequence", steps.value(i)),
                ));
            }
        }
    }
    Ok(paths)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{Cell, Pose};

    fn geo() -> GeoRef {
        GeoRef::square(3, 2, 0.25, [1.0, 2.0], "odom")
    }

    #[test]
    fn rasters_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let map = Map {
            name: "m".into(),
            geo: geo(),
            layers: vec![
                Layer::new("elevation", vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
                Layer::new("road", vec![0.0, 1.0, 0.0, 1.0, 0.0, 1.0]),
                Layer::new("land_cover", vec![11.0, 21.0, 41.0, 11.0, 90.0, 95.0])
                    .declared_classes(),
            ],
        };
        let p = dir.path().join("map.parquet");
        write_map(&p, &map).unwrap();
        assert_eq!(read_map(&p).unwrap(), map);

        let stack = FeatureStack {
            geo: geo(),
            names: vec!["a".into(), "b".into()],
            data: (0..12).map(|v| v as f32).collect(),
        };
        let spec = serde_json::json!({"bias": true});
        let p = dir.path().join("features.parquet");
        write_features(&p, "m", &stack, &spec).unwrap();
        assert_eq!(read_features(&p).unwrap(), ("m".to_string(), stack, spec));

        let costs = Grid::from_vec(geo(), vec![0.5, 1.0, 2.0, 4.0, 8.0, 16.0]);
        let p = dir.path().join("costmap.parquet");
        write_costmap(&p, "m", &costs).unwrap();
        assert_eq!(read_costmap(&p).unwrap(), ("m".to_string(), costs));
    }

    #[test]
    fn demonstrations_and_paths_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let demos = vec![
            Demonstration {
                episode: "a".into(),
                map: "m".into(),
                poses: vec![
                    Pose {
                        t: 0.0,
                        x: 1.0,
                        y: 2.0,
                        yaw: Some(0.5),
                    },
                    Pose {
                        t: 1.0,
                        x: 1.5,
                        y: 2.0,
                        yaw: None,
                    },
                ],
            },
            Demonstration {
                episode: "b".into(),
                map: "m".into(),
                poses: vec![Pose {
                    t: 3.0,
                    x: 1.0,
                    y: 2.0,
                    yaw: None,
                }],
            },
        ];
        let p = dir.path().join("demos.parquet");
        write_demonstrations(&p, &demos).unwrap();
        assert_eq!(
            crate::io::demo_tables::read_demonstrations(&p).unwrap(),
            demos
        );

        let paths = vec![
            EpisodePath {
                episode: "a".into(),
                map: "m".into(),
                cells: vec![Cell::new(0, 0), Cell::new(0, 1)],
            },
            EpisodePath {
                episode: "b".into(),
                map: "m".into(),
                cells: vec![Cell::new(1, 1)],
            },
        ];
        let p = dir.path().join("paths.parquet");
        write_paths(&p, &paths).unwrap();
        assert_eq!(read_paths(&p).unwrap(), paths);
    }

    #[test]
    fn wrong_and_unknown_schema_tags_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let costs = Grid::from_vec(geo(), vec![1.0; 6]);
        let p = dir.path().join("costmap.parquet");
        write_costmap(&p, "m", &costs).unwrap();
        let err = read_map(&p).unwrap_err().to_string();
        assert!(
            err.contains("costmap.parquet")
                && err.contains("'costmap/1'")
                && err.contains("'map/1'"),
            "{err}"
        );
        assert!(
            check_schema_tag(&p, Some("map/2"), Table::MAP, false)
                .unwrap_err()
                .to_string()
                .contains("reads 'map/1' only")
        );
        assert!(check_schema_tag(&p, None, Table::MAP, false).is_err());
        assert!(check_schema_tag(&p, None, Table::DEMONSTRATIONS, true).is_ok());
        let err = read_map(&dir.path().join("missing.parquet")).unwrap_err();
        assert_eq!(err.exit_code(), 2);
        std::fs::write(dir.path().join("junk.parquet"), b"not parquet").unwrap();
        let err = read_map(&dir.path().join("junk.parquet"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("not a readable Parquet file"), "{err}");
    }
}
