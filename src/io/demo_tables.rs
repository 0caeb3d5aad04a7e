//! Demonstrations from other people's tables: Parquet with their own column names
//! (elements of list columns included, e.g. `observation.state[0]`, integer episode ids),
//! and LeRobot v2/v3 dataset folders (`meta/info.json`, `data/chunk-*/...parquet`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use arrow::array::{Array, ArrayRef, AsArray, RecordBatch};
use arrow::datatypes::{DataType, Float64Type};

use super::tables::{Table, read_table};
use crate::error::{Error, Result, read_input};
use crate::grid::{Demonstration, Pose};

/// A column, or one element of a list column: `name` or `name[index]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Column {
    pub name: String,
    pub index: Option<usize>,
}

impl Column {
    pub fn named(name: &str) -> Column {
        Column {
            name: name.to_string(),
            index: None,
        }
    }
}

impl FromStr for Column {
    type Err = String;

    fn from_str(text: &str) -> std::result::Result<Self, String> {
        let text = text.trim();
        match text.strip_suffix(']').and_then(|t| t.rsplit_once('[')) {
            Some((name, index)) => Ok(Column {
                name: name.to_string(),
                index: Some(
                    index
                        .parse()
                        .map_err(|_| format!("'{text}': '{index}' is not an element index"))?,
                ),
            }),
            None if !text.is_empty() => Ok(Column::named(text)),
            None => Err("an empty column name".into()),
        }
    }
}

impl std::fmt::Display for Column {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.index {
            Some(i) => write!(f, "{}[{i}]", self.name),
            None => f.write_str(&self.name),
        }
    }
}

/// Which column plays which role in a demonstrations table.
#[derive(Debug, Clone, PartialEq)]
pub struct Columns {
    pub episode: Column,
    /// `None`: every row lies on the default map.
    pub map: Option<Column>,
    pub t: Column,
    pub x: Column,
    pub y: Column,
    pub yaw: Option<Column>,
}

impl Default for Columns {
    /// The `demonstrations/1` table's own names.
    fn default() -> Self {
        Columns {
            episode: Column::named("episode"),
            map: Some(Column::named("map")),
            t: Column::named("t"),
            x: Column::named("x"),
            y: Column::named("y"),
            yaw: Some(Column::named("yaw")),
        }
    }
}

impl Columns {
    /// Applies `role=column` overrides (roles: episode, map, t, x, y, yaw).
    pub fn with_overrides(mut self, overrides: &[String]) -> std::result::Result<Self, String> {
        for item in overrides {
            let (role, column) = item
                .split_once('=')
                .ok_or_else(|| format!("column mapping '{item}' is not ROLE=COLUMN"))?;
            let column: Column = column.parse()?;
            match role.trim() {
                "episode" => self.episode = column,
                "map" => self.map = Some(column),
                "t" => self.t = column,
                "x" => self.x = column,
                "y" => self.y = column,
                "yaw" => self.yaw = Some(column),
                other => {
                    return Err(format!(
                        "unknown column role '{other}' (roles: episode, map, t, x, y, yaw)"
                    ));
                }
            }
        }
        Ok(self)
    }
}

/// Finds a column of the batch, with an error naming the file.
fn array<'a>(path: &Path, batch: &'a RecordBatch, column: &Column) -> Result<&'a ArrayRef> {
    batch.column_by_name(&column.name).ok_or_else(|| {
        let names: Vec<String> = batch
            .schema()
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect();
        Error::input(
            path,
            format!(
                "has no column '{}' (columns: {})",
                column.name,
                names.join(", ")
            ),
        )
    })
}

/// Numbers of a column or of one element of a list column; nulls stay `None`.
fn numbers(path: &Path, batch: &RecordBatch, column: &Column) -> Result<Vec<Option<f64>>> {
    let values = array(path, batch, column)?;
    let as_f64 = |array: &dyn Array| -> Result<Vec<Option<f64>>> {
        if !array.data_type().is_numeric() {
            return Err(Error::input(
                path,
                format!(
                    "column '{column}' has type {}, expected numbers",
                    array.data_type()
                ),
            ));
        }
        let cast = arrow::compute::cast(array, &DataType::Float64)
            .map_err(|e| Error::input(path, format!("column '{column}': {e}")))?;
        Ok(cast.as_primitive::<Float64Type>().iter().collect())
    };
    let Some(index) = column.index else {
        return as_f64(values.as_ref());
    };
    let element = |row: usize, start: usize, length: usize, items: &[Option<f64>]| {
        if index >= length {
            return Err(Error::input(
                path,
                format!(
                    "record {row}: column '{}' holds {length} values, no element {index}",
                    column.name
                ),
            ));
        }
        Ok(items[start + index])
    };
    match values.data_type() {
        DataType::FixedSizeList(_, length) => {
            let list = values.as_fixed_size_list();
            let items = as_f64(list.values().as_ref())?;
            let length = *length as usize;
            (0..list.len())
                .map(|row| {
                    if list.is_null(row) {
                        Ok(None)
                    } else {
                        element(row, row * length, length, &items)
                    }
                })
                .collect()
        }
        DataType::List(_) => {
            let list = values.as_list::<i32>();
            let items = as_f64(list.values().as_ref())?;
            let offsets = list.value_offsets();
            (0..list.len())
                .map(|row| {
                    let (start, end) = (offsets[row] as usize, offsets[row + 1] as usize);
                    if list.is_null(row) {
                        Ok(None)
                    } else {
                        element(row, start, end - start, &items)
                    }
                })
                .collect()
        }
        other => Err(Error::input(
            path,
            format!(
                "column '{}' has type {other}; '{column}' needs a list column",
                column.name
            ),
        )),
    }
}

/// The numbers under each element of `array` (a number column, or lists of lists ... of
/// numbers, to any depth): element i's are `leaves[offsets[i]..offsets[i + 1]]`. Nulls
/// stay `None`; what is not a number or a list is `Err` with its type.
fn leaf_offsets(
    array: &dyn Array,
) -> std::result::Result<(Vec<usize>, Vec<Option<f64>>), DataType> {
    let nested = |child: &dyn Array, ranges: Vec<usize>| {
        let (child_offsets, leaves) = leaf_offsets(child)?;
        Ok((ranges.iter().map(|&c| child_offsets[c]).collect(), leaves))
    };
    match array.data_type() {
        DataType::FixedSizeList(_, length) => {
            let list = array.as_fixed_size_list();
            let n = *length as usize;
            nested(
                list.values().as_ref(),
                (0..=list.len()).map(|i| i * n).collect(),
            )
        }
        DataType::List(_) => {
            let list = array.as_list::<i32>();
            let ranges = list.value_offsets().iter().map(|&o| o as usize).collect();
            nested(list.values().as_ref(), ranges)
        }
        DataType::LargeList(_) => {
            let list = array.as_list::<i64>();
            let ranges = list.value_offsets().iter().map(|&o| o as usize).collect();
            nested(list.values().as_ref(), ranges)
        }
        t if t.is_numeric() => {
            let cast = arrow::compute::cast(array, &DataType::Float64).map_err(|_| t.clone())?;
            let leaves = cast.as_primitive::<Float64Type>().iter().collect();
            Ok(((0..=array.len()).collect(), leaves))
        }
        other => Err(other.clone()),
    }
}

/// Per row, the numbers of `column`: one for a number column, all of them for a list
/// column (a list of lists, such as an action chunk of several vectors per frame, gives
/// them all in order), and with `name[i]` those of element i of the list (a number, or
/// the i-th vector of a chunk). A null is an error naming the record.
pub fn row_vectors(path: &Path, batch: &RecordBatch, column: &Column) -> Result<Vec<Vec<f64>>> {
    let values = array(path, batch, column)?;
    let null = |row: usize| Error::input(path, format!("record {row}: column '{column}' is null"));
    let not_numbers = |t: DataType| {
        Error::input(
            path,
            format!("column '{column}' holds {t}, expected numbers or lists of numbers"),
        )
    };
    // Per row, which elements of the row's list (or the row itself) to take.
    let (rows, elements): (Vec<std::ops::Range<usize>>, &dyn Array) = match column.index {
        None => (
            (0..values.len()).map(|r| r..r + 1).collect(),
            values.as_ref(),
        ),
        Some(index) => {
            let (ranges, child): (Vec<usize>, &dyn Array) = match values.data_type() {
                DataType::FixedSizeList(_, n) => {
                    let list = values.as_fixed_size_list();
                    let n = *n as usize;
                    (
                        (0..=list.len()).map(|i| i * n).collect(),
                        list.values().as_ref(),
                    )
                }
                DataType::List(_) => {
                    let list = values.as_list::<i32>();
                    let ranges = list.value_offsets().iter().map(|&o| o as usize).collect();
                    (ranges, list.values().as_ref())
                }
                other => {
                    return Err(Error::input(
                        path,
                        format!(
                            "column '{}' has type {other}; '{column}' needs a list column",
                            column.name
                        ),
                    ));
                }
            };
            let rows = (0..values.len())
                .map(|row| {
                    let length = ranges[row + 1] - ranges[row];
                    if index >= length && !values.is_null(row) {
                        return Err(Error::input(
                            path,
                            format!(
                                "record {row}: column '{}' holds {length} values, no element {index}",
                                column.name
                            ),
                        ));
                    }
                    Ok(ranges[row] + index..ranges[row] + index + 1)
                })
                .collect::<Result<_>>()?;
            (rows, child)
        }
    };
    let (offsets, leaves) = leaf_offsets(elements).map_err(not_numbers)?;
    rows.into_iter()
        .enumerate()
        .map(|(row, taken)| {
            if values.is_null(row) {
                return Err(null(row));
            }
            leaves[offsets[taken.start]..offsets[taken.end]]
                .iter()
                .map(|v| v.ok_or_else(|| null(row)))
                .collect()
        })
        .collect()
}

/// Per row, whether the values `column` takes are padding, from LeRobot's
/// `<name>_is_pad` column beside it (a bool, or a list of bools per element of an
/// action chunk): padded values repeat the episode's last frame and teach nothing.
/// With `name[i]` element i's flag counts, otherwise any element's. `None` when the
/// table has no such column.
pub fn padding(path: &Path, batch: &RecordBatch, column: &Column) -> Result<Option<Vec<bool>>> {
    let name = format!("{}_is_pad", column.name);
    let Some(flags) = batch.column_by_name(&name) else {
        return Ok(None);
    };
    let null = |row: usize| Error::input(path, format!("record {row}: column '{name}' is null"));
    let not_flags = |t: &DataType| {
        Error::input(
            path,
            format!("column '{name}' holds {t}, expected booleans or lists of booleans"),
        )
    };
    let rows = flags.len();
    let (ranges, values): (Vec<usize>, &dyn Array) = match flags.data_type() {
        DataType::Boolean => ((0..=rows).collect(), flags.as_ref()),
        DataType::List(_) => {
            let list = flags.as_list::<i32>();
            let ranges = list.value_offsets().iter().map(|&o| o as usize).collect();
            (ranges, list.values().as_ref())
        }
        DataType::LargeList(_) => {
            let list = flags.as_list::<i64>();
            let ranges = list.value_offsets().iter().map(|&o| o as usize).collect();
            (ranges, list.values().as_ref())
        }
        DataType::FixedSizeList(_, n) => {
            let list = flags.as_fixed_size_list();
            let n = *n as usize;
            ((0..=rows).map(|i| i * n).collect(), list.values().as_ref())
        }
        other => return Err(not_flags(other)),
    };
    let Some(values) = values.as_boolean_opt() else {
        return Err(not_flags(values.data_type()));
    };
    (0..rows)
        .map(|row| {
            if flags.is_null(row) {
                return Err(null(row));
            }
            let taken = match (column.index, flags.data_type()) {
                (
                    Some(i),
                    DataType::List(_) | DataType::LargeList(_) | DataType::FixedSizeList(..),
                ) => {
                    let at = ranges[row] + i;
                    if at >= ranges[row + 1] {
                        return Err(Error::input(
                            path,
                            format!(
                                "record {row}: column '{name}' holds {} flags, no element {i}",
                                ranges[row + 1] - ranges[row]
                            ),
                        ));
                    }
                    at..at + 1
                }
                _ => ranges[row]..ranges[row + 1],
            };
            taken
                .map(|i| {
                    if values.is_null(i) {
                        Err(null(row))
                    } else {
                        Ok(values.value(i))
                    }
                })
                .try_fold(false, |any, flag| flag.map(|f| any || f))
        })
        .collect::<Result<Vec<bool>>>()
        .map(Some)
}

/// Episode ids as text: string columns as they are, integer ids in decimal.
pub fn labels(path: &Path, batch: &RecordBatch, column: &Column) -> Result<Vec<String>> {
    let values = array(path, batch, column)?;
    if let Some(row) = (0..values.len()).find(|&i| values.is_null(i)) {
        return Err(Error::input(
            path,
            format!("record {row}: column '{column}' is null"),
        ));
    }
    match values.data_type() {
        DataType::Utf8 | DataType::LargeUtf8 | DataType::Utf8View => {
            let cast = arrow::compute::cast(values, &DataType::Utf8)
                .map_err(|e| Error::input(path, format!("column '{column}': {e}")))?;
            Ok(cast
                .as_string::<i32>()
                .iter()
                .map(|s| s.unwrap_or_default().to_string())
                .collect())
        }
        t if t.is_integer() => {
            let cast = arrow::compute::cast(values, &DataType::Int64)
                .map_err(|e| Error::input(path, format!("column '{column}': {e}")))?;
            Ok(cast
                .as_primitive::<arrow::datatypes::Int64Type>()
                .iter()
                .map(|v| v.unwrap_or_default().to_string())
                .collect())
        }
        other => Err(Error::input(
            path,
            format!("column '{column}' has type {other}, expected text or integers"),
        )),
    }
}

/// Demonstrations from the rows of `batch` (read from `path`): rows of an episode are
/// consecutive, in increasing time. Rows without a map column lie on `default_map`.
/// Episode names get `prefix` in front.
pub fn demonstrations_from_rows(
    path: &Path,
    batch: &RecordBatch,
    columns: &Columns,
    default_map: Option<&str>,
    prefix: &str,
) -> Result<Vec<Demonstration>> {
    // A table with no episode column of the default name (one track exported to CSV)
    // is one episode, named after its file.
    let whole_file = columns.episode == Column::named("episode")
        && batch.column_by_name(&columns.episode.name).is_none();
    let episodes = if whole_file {
        let stem = path.file_stem().unwrap_or_default().to_string_lossy();
        vec![stem.into_owned(); batch.num_rows()]
    } else {
        labels(path, batch, &columns.episode)?
    };
    // A map column that is named but absent falls back to the default map, if any.
    let map_column = columns
        .map
        .as_ref()
        .filter(|c| batch.column_by_name(&c.name).is_some() || default_map.is_none());
    let maps = match (map_column, default_map) {
        (Some(column), _) => labels(path, batch, column)?,
        (None, Some(map)) => vec![map.to_string(); batch.num_rows()],
        (None, None) => {
            return Err(Error::input(
                path,
                "has no map column and no default map is given (default_map)",
            ));
        }
    };
    let required = |column: &Column| -> Result<Vec<f64>> {
        numbers(path, batch, column)?
            .into_iter()
            .enumerate()
            .map(|(i, v)| match v {
                Some(v) if v.is_finite() => Ok(v),
                Some(v) => Err(Error::input(
                    path,
                    format!("record {i}: column '{column}' is {v}, expected a finite number"),
                )),
                None => Err(Error::input(
                    path,
                    format!("record {i}: column '{column}' is null"),
                )),
            })
            .collect()
    };
    let (t, x, y) = (
        required(&columns.t)?,
        required(&columns.x)?,
        required(&columns.y)?,
    );
    let yaw = match &columns.yaw {
        Some(column) if batch.column_by_name(&column.name).is_some() => {
            numbers(path, batch, column)?
        }
        _ => vec![None; batch.num_rows()],
    };
    let mut demos: Vec<Demonstration> = Vec::new();
    for i in 0..batch.num_rows() {
        let pose = Pose {
            t: t[i],
            x: x[i],
            y: y[i],
            yaw: yaw[i],
        };
        let episode = format!("{prefix}{}", episodes[i]);
        match demos.last_mut() {
            Some(d) if d.episode == episode => {
                if d.map != maps[i] {
                    return Err(Error::input(
                        path,
                        format!(
                            "record {i}: episode '{}' changes map from '{}' to '{}'",
                            d.episode, d.map, maps[i]
                        ),
                    ));
                }
                let last_t = d.poses.last().map_or(f64::NEG_INFINITY, |p| p.t);
                if pose.t <= last_t {
                    let hint = if whole_file {
                        ": with no episode column the table is one episode; name the column \
                         that tells episodes apart (--column episode=COLUMN)"
                    } else {
                        ""
                    };
                    return Err(Error::input(
                        path,
                        format!(
                            "record {i}: episode '{}' goes back in time (t {} after \
                             {last_t}){hint}",
                            d.episode, pose.t
                        ),
                    ));
                }
                d.poses.push(pose);
            }
            _ => {
                if demos.iter().any(|d| d.episode == episode) {
                    return Err(Error::input(
                        path,
                        format!("record {i}: rows of episode '{episode}' are not consecutive"),
                    ));
                }
                demos.push(Demonstration {
                    episode,
                    map: maps[i].clone(),
                    poses: vec![pose],
                });
            }
        }
    }
    if demos.is_empty() {
        return Err(Error::input(path, "holds no demonstrations"));
    }
    Ok(demos)
}

/// Reads a demonstrations table. Files without an `imitate.schema` tag are accepted when
/// their columns fit, so that tables written by pandas or polars work as they are.
pub fn read_demonstrations_table(
    path: &Path,
    columns: &Columns,
    default_map: Option<&str>,
) -> Result<Vec<Demonstration>> {
    let is_csv = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
    let batch = if is_csv {
        read_csv(path)?
    } else {
        read_table(path, Table::DEMONSTRATIONS, true)?.batch
    };
    demonstrations_from_rows(path, &batch, columns, default_map, "")
}

/// A CSV file with a header row (as pandas' `to_csv`, polars' `write_csv`, spreadsheets
/// and ROS bag exporters write them) as one record batch, each column's type inferred
/// from its values as Arrow infers them (integers, floats, text; empty fields null).
/// The delimiter is the header's commonest of comma, semicolon and tab (a spreadsheet
/// in a locale whose decimal mark is a comma saves semicolons); a UTF-8 byte-order
/// mark (Excel's "CSV UTF-8") is passed over.
fn read_csv(path: &Path) -> Result<RecordBatch> {
    use arrow::csv::reader::{Format, ReaderBuilder};
    let problem =
        |e: arrow::error::ArrowError| Error::input(path, format!("not a readable CSV file: {e}"));
    let mut bytes = read_input(path)?;
    if bytes.starts_with(b"\xEF\xBB\xBF") {
        bytes.drain(..3);
    }
    let header = bytes.split(|&b| b == b'\n').next().unwrap_or_default();
    let delimiter = [b',', b';', b'\t']
        .into_iter()
        .max_by_key(|&d| (header.iter().filter(|&&b| b == d).count(), d == b','))
        .unwrap_or(b',');
    let format = Format::default()
        .with_header(true)
        .with_delimiter(delimiter);
    let (schema, _) = format
        .infer_schema(std::io::Cursor::new(&bytes), None)
        .map_err(problem)?;
    let schema = std::sync::Arc::new(schema);
    let batches = ReaderBuilder::new(schema.clone())
        .with_format(format)
        .build(std::io::Cursor::new(&bytes))
        .map_err(problem)?
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(problem)?;
    arrow::compute::concat_batches(&schema, &batches).map_err(problem)
}

/// Reads a `demonstrations/1` table (or any table with its column names).
pub fn read_demonstrations(path: &Path) -> Result<Vec<Demonstration>> {
    read_demonstrations_table(path, &Columns::default(), None)
}

/// The LeRobot names for the pose inside `observation.state`, when `meta/info.json` names
/// its elements: x, y and yaw (or theta, heading).
/// The element names `meta/info.json` gives a LeRobot feature (`observation.state`,
/// `action`): a list, or a map holding one list (v2.0's `{"motors": [...]}`). `None` when
/// it names none.
fn feature_element_names(info: &serde_json::Value, feature: &str) -> Option<Vec<String>> {
    let names = info.get("features")?.get(feature)?.get("names")?;
    let list = match names {
        serde_json::Value::Array(items) => items,
        serde_json::Value::Object(map) => map.values().next()?.as_array()?,
        _ => return None,
    };
    list.iter().map(|n| n.as_str().map(String::from)).collect()
}

/// The names of a LeRobot feature's elements, from `meta/info.json`: its `names`, or
/// `feature[i]` for each element of its `shape` when it has none.
pub fn lerobot_feature_names(folder: &Path, feature: &str) -> Result<Vec<String>> {
    let info_path = folder.join("meta/info.json");
    let info: serde_json::Value = serde_json::from_slice(&read_input(&info_path)?)
        .map_err(|e| Error::input(&info_path, format!("not JSON: {e}")))?;
    if let Some(names) = feature_element_names(&info, feature) {
        return Ok(names);
    }
    let shape = info
        .get("features")
        .and_then(|f| f.get(feature))
        .and_then(|f| f.get("shape"))
        .and_then(|s| s.as_array())
        .ok_or_else(|| {
            Error::input(
                &info_path,
                format!("describes no feature '{feature}' (features.{feature}.shape)"),
            )
        })?;
    let count = shape
        .iter()
        .map(|d| d.as_u64())
        .product::<Option<u64>>()
        .filter(|&n| (1..=1 << 16).contains(&n))
        .ok_or_else(|| {
            Error::input(
                &info_path,
                format!("features.{feature}.shape is not a list of sizes"),
            )
        })?;
    Ok((0..count).map(|i| format!("{feature}[{i}]")).collect())
}

/// The features of a LeRobot folder's `meta/info.json` that are images or videos (not in
/// the tables), with their dtype.
pub fn lerobot_picture_features(folder: &Path) -> Result<Vec<(String, String)>> {
    let info_path = folder.join("meta/info.json");
    let info: serde_json::Value = serde_json::from_slice(&read_input(&info_path)?)
        .map_err(|e| Error::input(&info_path, format!("not JSON: {e}")))?;
    let features = info.get("features").and_then(|f| f.as_object());
    Ok(features
        .into_iter()
        .flatten()
        .filter_map(|(name, feature)| {
            let dtype = feature.get("dtype")?.as_str()?;
            matches!(dtype, "video" | "image").then(|| (name.clone(), dtype.to_string()))
        })
        .collect())
}

fn lerobot_columns(info: &serde_json::Value) -> Option<Columns> {
    let names = feature_element_names(info, "observation.state")?;
    let element = |wanted: &[&str]| {
        names
            .iter()
            .position(|n| wanted.contains(&n.to_ascii_lowercase().as_str()))
            .map(|index| Column {
                name: "observation.state".into(),
                index: Some(index),
            })
    };
    Some(Columns {
        episode: Column::named("episode_index"),
        map: None,
        t: Column::named("timestamp"),
        x: element(&["x"])?,
        y: element(&["y"])?,
        yaw: element(&["yaw", "theta", "heading"]),
    })
}

/// The data files of a LeRobot folder, in name order.
pub fn lerobot_files(folder: &Path) -> Result<Vec<PathBuf>> {
    let pattern = folder.join("data/**/*.parquet");
    let mut files: Vec<PathBuf> = glob::glob(&pattern.to_string_lossy())
        .map_err(|e| Error::input(folder, e.to_string()))?
        .filter_map(|entry| entry.ok())
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(Error::input(folder, "has no data/**/*.parquet files"));
    }
    Ok(files)
}

/// Reads a LeRobot dataset folder (codebase v2.x: one file per episode; v3.x: files of
/// several episodes). Episodes are named `<folder>-episode-<index>`; the pose comes from
/// `observation.state` elements named x, y (and yaw) in `meta/info.json`, unless
/// `overrides` (`role=column`) say otherwise.
pub fn read_lerobot(
    folder: &Path,
    overrides: &[String],
    default_map: Option<&str>,
) -> Result<Vec<Demonstration>> {
    let info_path = folder.join("meta/info.json");
    let info: serde_json::Value = serde_json::from_slice(&read_input(&info_path)?)
        .map_err(|e| Error::input(&info_path, format!("not JSON: {e}")))?;
    let version = info
        .get("codebase_version")
        .and_then(|v| v.as_str())
        .unwrap_or_default();
    if !(version.starts_with("v2") || version.starts_with("v3")) {
        return Err(Error::input(
            &info_path,
            format!("codebase_version '{version}': LeRobot v2.x and v3.x datasets are read"),
        ));
    }
    let files = lerobot_files(folder)?;
    let base = lerobot_columns(&info).unwrap_or_else(|| Columns {
        episode: Column::named("episode_index"),
        map: None,
        t: Column::named("timestamp"),
        x: Column::named("x"),
        y: Column::named("y"),
        yaw: None,
    });
    let columns = base
        .with_overrides(overrides)
        .map_err(|e| Error::Usage(e.to_string()))?;
    let prefix = format!(
        "{}-episode-",
        folder
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    );
    let mut demos: Vec<Demonstration> = Vec::new();
    let mut seen: BTreeMap<String, PathBuf> = BTreeMap::new();
    for file in &files {
        let table = read_table(file, Table::DEMONSTRATIONS, true)?;
        for demo in demonstrations_from_rows(file, &table.batch, &columns, default_map, &prefix)? {
            if let Some(first) = seen.insert(demo.episode.clone(), file.clone()) {
                return Err(Error::input(
                    file,
                    format!(
                        "episode '{}' continues from {}; episodes must not span files",
                        demo.episode,
                        first.display()
                    ),
                ));
            }
            demos.push(demo);
        }
    }
    Ok(demos)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_columns_and_overrides() {
        assert_eq!(
            "observation.state[2]".parse::<Column>().unwrap(),
            Column {
                name: "observation.state".into(),
                index: Some(2)
            }
        );
        assert!("a[x]".parse::<Column>().is_err());
        let columns = Columns::default()
            .with_overrides(&["t=timestamp".into(), "x=pos[0]".into()])
            .unwrap();
        assert_eq!(columns.t, Column::named("timestamp"));
        assert_eq!(columns.x.to_string(), "pos[0]");
        let err = Columns::default()
            .with_overrides(&["z=h".into()])
            .unwrap_err();
        assert!(err.contains("unknown column role 'z'"), "{err}");
    }

    #[test]
    fn row_vectors_take_numbers_lists_and_action_chunks() {
        use arrow::array::{FixedSizeListArray, Float32Array, Int64Array, ListArray};
        use arrow::buffer::OffsetBuffer;
        use arrow::datatypes::{Field, Schema};
        use std::sync::Arc;
        // Two frames, each a chunk of two 3-vectors: List<FixedSizeList<f32, 3>>.
        let item = Arc::new(Field::new("item", DataType::Float32, true));
        let vectors = FixedSizeListArray::new(
            item.clone(),
            3,
            Arc::new(Float32Array::from_iter_values((0..12).map(|v| v as f32))),
            None,
        );
        let vector_field = Arc::new(Field::new("item", vectors.data_type().clone(), true));
        let chunks = ListArray::new(
            vector_field,
            OffsetBuffer::from_lengths([2, 2]),
            Arc::new(vectors),
            None,
        );
        let schema = Schema::new(vec![
            Field::new("action", chunks.data_type().clone(), true),
            Field::new("step", DataType::Int64, true),
        ]);
        let batch = RecordBatch::try_new(
            Arc::new(schema),
            vec![Arc::new(chunks), Arc::new(Int64Array::from(vec![7, 8]))],
        )
        .unwrap();
        let path = Path::new("chunks.parquet");
        let rows = |text: &str| row_vectors(path, &batch, &text.parse().unwrap());
        assert_eq!(rows("action").unwrap()[1], [6.0, 7.0, 8.0, 9.0, 10.0, 11.0]);
        assert_eq!(rows("action[1]").unwrap()[0], [3.0, 4.0, 5.0]);
        assert_eq!(rows("step").unwrap(), [[7.0], [8.0]]);
        let err = rows("action[2]").unwrap_err().to_string();
        assert!(
            err.contains("record 0") && err.contains("no element 2"),
            "{err}"
        );
        let err = rows("step[0]").unwrap_err().to_string();
        assert!(err.contains("needs a list column"), "{err}");
    }
}
