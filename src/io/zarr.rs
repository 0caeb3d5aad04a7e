//! Zarr stores (`x.zarr` folders, version 2 and 3), as xarray's `to_zarr`, rioxarray
//! and zarr-python write gridded data, read with the CF conventions GDAL's Zarr driver
//! and xarray read them by:
//!
//! - the store's arrays are its folders holding `.zarray` (version 2) or a `zarr.json`
//!   of an array (version 3); an array's dimensions are named by `_ARRAY_DIMENSIONS`
//!   (xarray's, version 2) or `dimension_names` (version 3);
//! - the gridded arrays are those of two or more dimensions whose last two have 1-D
//!   coordinate arrays of their names (y then x, cell centres, evenly spaced; y either
//!   way); the first sets the grid and every gridded array on it is read, a layer each
//!   (one per step of leading dimensions such as time or band);
//! - chunks (C order, regular grid, missing ones holding the fill value) are decoded
//!   from Blosc (LZ4, Zstandard or zlib inside), Zstandard, zlib, gzip or LZ4 (version
//!   2's compressor) or the `bytes`, `zstd`, `gzip`, `blosc` and `crc32c` codecs
//!   (version 3), in shards (`sharding_indexed`: inner chunks and their index at either
//!   end); other codecs, filters and Fortran order are refused by name;
//! - the CRS is the WKT of the array's `grid_mapping` (`crs_wkt` or `spatial_ref`, as
//!   rioxarray writes it), else of its `_CRS` (as GDAL's Zarr driver writes it), else
//!   WGS 84 for coordinates in degrees, else a `.prj` or GDAL sidecar beside the store;
//! - values equal to `_FillValue` or `missing_value` (else version 2's `fill_value`, as
//!   GDAL and xarray take it) are nodata; `scale_factor` and `add_offset` unpack them.

use std::path::{Path, PathBuf};

use base64::Engine as _;
use rayon::prelude::*;
use serde_json::{Map as JsonMap, Value};

use super::FileOrder;
use super::MAX_MAP_CELLS;
use super::ascii_grid::crs_keys;
use super::blosc;
use super::geotiff::{Georeferencing, georeference, wkt_geokeys};
use super::named_crs::{self, Named};
use super::netcdf::{kilometres, spacing, unwrap_longitudes};
use super::sidecar_bands::{self, FileMasks, Samples};
use crate::error::{Error, Result, read_input};
use crate::grid::Map;

/// Whether `path` is a Zarr store (or array): a folder holding Zarr metadata.
pub fn is_zarr(path: &Path) -> bool {
    [".zgroup", ".zarray", "zarr.json", ".zmetadata"]
        .iter()
        .any(|m| path.join(m).is_file())
}

/// How a stored element is laid out.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Unsigned,
    Signed,
    Float,
    Bool,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct DataType {
    kind: Kind,
    size: usize,
    little: bool,
}

impl DataType {
    /// A version 2 `dtype` (`<f4`, `|u1`, `>i2`...).
    fn of_v2(dtype: &str) -> std::result::Result<Self, String> {
        let bytes = dtype.as_bytes();
        let (order, kind, size) = match bytes {
            [order, kind, size @ ..] => (*order, *kind, std::str::from_utf8(size).ok()),
            _ => (0, 0, None),
        };
        let size: usize = size.and_then(|s| s.parse().ok()).unwrap_or(0);
        let kind = match (kind, size) {
            (b'f', 4 | 8) => Kind::Float,
            (b'i', 1 | 2 | 4 | 8) => Kind::Signed,
            (b'u', 1 | 2 | 4 | 8) => Kind::Unsigned,
            (b'b', 1) => Kind::Bool,
            _ => {
                return Err(format!(
                    "its dtype '{dtype}' is not a number type read here"
                ));
            }
        };
        Ok(DataType {
            kind,
            size,
            little: order != b'>',
        })
    }

    /// A version 3 `data_type` (`float32`, `int16`, `bool`...), little-endian until the
    /// `bytes` codec says otherwise.
    fn of_v3(name: &str) -> std::result::Result<Self, String> {
        let (kind, size) = match name {
            "bool" => (Kind::Bool, 1),
            "int8" => (Kind::Signed, 1),
            "int16" => (Kind::Signed, 2),
            "int32" => (Kind::Signed, 4),
            "int64" => (Kind::Signed, 8),
            "uint8" => (Kind::Unsigned, 1),
            "uint16" => (Kind::Unsigned, 2),
            "uint32" => (Kind::Unsigned, 4),
            "uint64" => (Kind::Unsigned, 8),
            "float32" => (Kind::Float, 4),
            "float64" => (Kind::Float, 8),
            other => {
                return Err(format!(
                    "its data_type '{other}' is not a number type read here"
                ));
            }
        };
        Ok(DataType {
            kind,
            size,
            little: true,
        })
    }

    /// Each element of `source` through `convert` into `out`: one loop per common
    /// type, the generic [`DataType::read`] for the rest.
    fn convert_run<T>(self, source: &[u8], out: &mut [T], convert: &impl Fn(f64) -> T) {
        /// Every `$n`-byte `$t` of `source`, in the file's byte order.
        macro_rules! each {
            ($t:ty, $n:literal) => {
                for (value, raw) in out.iter_mut().zip(source.chunks_exact($n)) {
                    let bytes: [u8; $n] = raw.try_into().expect("an element's bytes");
                    let element = if self.little {
                        <$t>::from_le_bytes(bytes)
                    } else {
                        <$t>::from_be_bytes(bytes)
                    };
                    *value = convert(f64::from(element));
                }
            };
        }
        match (self.kind, self.size) {
            (Kind::Unsigned | Kind::Bool, 1) => each!(u8, 1),
            (Kind::Signed, 1) => each!(i8, 1),
            (Kind::Unsigned, 2) => each!(u16, 2),
            (Kind::Signed, 2) => each!(i16, 2),
            (Kind::Unsigned, 4) => each!(u32, 4),
            (Kind::Signed, 4) => each!(i32, 4),
            (Kind::Float, 4) => each!(f32, 4),
            (Kind::Float, 8) => each!(f64, 8),
            _ => {
                for (value, raw) in out.iter_mut().zip(source.chunks_exact(self.size)) {
                    *value = convert(self.read(raw));
                }
            }
        }
    }

    /// The element in `raw` (its `size` bytes).
    fn read(self, raw: &[u8]) -> f64 {
        let mut word = [0u8; 8];
        word[..self.size].copy_from_slice(&raw[..self.size]);
        if !self.little {
            word[..self.size].reverse();
        }
        let bits = u64::from_le_bytes(word);
        match (self.kind, self.size) {
            (Kind::Float, 4) => f64::from(f32::from_bits(bits as u32)),
            (Kind::Float, _) => f64::from_bits(bits),
            (Kind::Signed, n) => {
                let shift = 64 - 8 * n as u32;
                (((bits << shift) as i64) >> shift) as f64
            }
            (Kind::Unsigned | Kind::Bool, _) => bits as f64,
        }
    }
}

/// One step of a chunk's decoding, from stored bytes toward elements.
#[derive(Debug, Clone, PartialEq)]
enum Step {
    Blosc,
    Zstd,
    Zlib,
    Gzip,
    /// numcodecs' LZ4: the size, then an LZ4 block.
    Lz4,
    /// A CRC-32C checksum after the bytes.
    Crc32c,
}

/// What an array's metadata says.
#[derive(Debug, Clone)]
struct Array {
    name: String,
    folder: PathBuf,
    shape: Vec<usize>,
    chunks: Vec<usize>,
    dtype: DataType,
    /// Decoding steps, in the order they are undone (of each shard, where sharded).
    steps: Vec<Step>,
    /// How each chunk (a shard) holds its inner chunks, where the array is sharded.
    shard: Option<Shard>,
    fill: Option<f64>,
    /// A chunk's key from its indices: the prefix and separator.
    key_prefix: &'static str,
    separator: String,
    dimensions: Vec<String>,
    attributes: JsonMap<String, Value>,
    version: u8,
}

/// Version 3's sharding: each chunk file a shard of inner chunks, each encoded on its
/// own, and an index of where each lies.
#[derive(Debug, Clone, PartialEq)]
struct Shard {
    inner: Vec<usize>,
    steps: Vec<Step>,
    /// Whether the index ends the shard (else it opens it).
    index_at_end: bool,
    /// Whether a CRC-32C checksum follows the index.
    index_checksum: bool,
}

/// The decoding steps (in the order they are undone) and sharding of version 3
/// `codecs`, the element byte order set in `dtype` by the `bytes` codec.
fn codecs(
    list: &Value,
    dtype: &mut DataType,
    outermost: bool,
) -> std::result::Result<(Vec<Step>, Option<Shard>), String> {
    let mut steps = Vec::new();
    let mut shard = None;
    for codec in list.as_array().ok_or("it lists no codecs")? {
        let configuration = &codec["configuration"];
        match codec["name"].as_str().unwrap_or_default() {
            "bytes" => dtype.little = configuration["endian"] != "big",
            "zstd" => steps.push(Step::Zstd),
            "gzip" => steps.push(Step::Gzip),
            "blosc" => steps.push(Step::Blosc),
            "crc32c" => steps.push(Step::Crc32c),
            "numcodecs.zlib" => steps.push(Step::Zlib),
            "sharding_indexed" if outermost => {
                let (inner_steps, _) = codecs(&configuration["codecs"], dtype, false)?;
                let mut index_dtype = DataType::of_v3("uint64").expect("a data type");
                let (index_steps, _) =
                    codecs(&configuration["index_codecs"], &mut index_dtype, false)?;
                if !index_dtype.little || index_steps.iter().any(|s| *s != Step::Crc32c) {
                    return Err(
                        "its shard index is not little-endian offsets with at most a \
                         CRC-32C checksum (as zarr writes it)"
                            .into(),
                    );
                }
                shard = Some(Shard {
                    inner: sizes(&configuration["chunk_shape"])
                        .ok_or("its shards' chunk_shape is not a list of sizes")?,
                    steps: inner_steps,
                    index_at_end: configuration["index_location"] != "start",
                    index_checksum: !index_steps.is_empty(),
                });
            }
            other => {
                return Err(format!(
                    "its codec '{other}' is not read (bytes, zstd, gzip, blosc, crc32c and \
                     sharding_indexed are)"
                ));
            }
        }
    }
    steps.reverse();
    Ok((steps, shard))
}

/// A JSON number, or the strings Zarr writes for non-finite floats and hex bits.
fn number(value: &Value, dtype: Option<DataType>) -> Option<f64> {
    match value {
        Value::Number(n) => n.as_f64(),
        Value::String(s) => match s.as_str() {
            "NaN" => Some(f64::NAN),
            "Infinity" => Some(f64::INFINITY),
            "-Infinity" => Some(f64::NEG_INFINITY),
            hex if hex.starts_with("0x") => {
                let bits = u64::from_str_radix(&hex[2..], 16).ok()?;
                match dtype {
                    Some(DataType { size: 4, .. }) => Some(f64::from(f32::from_bits(bits as u32))),
                    _ => Some(f64::from_bits(bits)),
                }
            }
            // xarray's base64 of the value's bytes (a float64 for floats).
            encoded => {
                let bytes = base64::engine::general_purpose::STANDARD
                    .decode(encoded)
                    .ok()?;
                let dtype = dtype?;
                let size = bytes.len();
                let as_type = DataType {
                    kind: dtype.kind,
                    size,
                    little: true,
                };
                matches!(size, 1 | 2 | 4 | 8).then(|| as_type.read(&bytes))
            }
        },
        Value::Bool(b) => Some(f64::from(u8::from(*b))),
        _ => None,
    }
}

fn read_json(path: &Path) -> Result<Value> {
    let bytes = read_input(path)?;
    serde_json::from_slice(&bytes).map_err(|e| Error::input(path, format!("not valid JSON: {e}")))
}

impl Array {
    /// The array whose metadata lies in `folder`, if it holds one; an error names the
    /// metadata file and what it cannot read.
    fn open(folder: &Path) -> Result<Option<Self>> {
        let v2 = folder.join(".zarray");
        let v3 = folder.join("zarr.json");
        let name = folder
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let (meta_path, meta) = if v2.is_file() {
            (v2.clone(), read_json(&v2)?)
        } else if v3.is_file() {
            let meta = read_json(&v3)?;
            if meta["node_type"] != "array" {
                return Ok(None);
            }
            (v3, meta)
        } else {
            return Ok(None);
        };
        let array = if meta_path == v2 {
            let attributes = match folder.join(".zattrs") {
                p if p.is_file() => read_json(&p)?.as_object().cloned().unwrap_or_default(),
                _ => JsonMap::new(),
            };
            Self::of_v2(name, folder, &meta, attributes)
        } else {
            Self::of_v3(name, folder, &meta)
        };
        array
            .and_then(Array::checked)
            .map(Some)
            .map_err(|e| Error::input(&meta_path, e))
    }

    /// The array, once its shape and chunks are known to be sizes a reader can hold:
    /// as many chunk sides as dimensions, none empty, a chunk under 2 GiB, a count of
    /// elements that fits in memory's address space.
    fn checked(self) -> std::result::Result<Self, String> {
        if self.chunks.len() != self.shape.len() {
            return Err(format!(
                "its chunks {:?} do not match its shape {:?}",
                self.chunks, self.shape
            ));
        }
        if self.chunks.contains(&0) {
            return Err(format!("its chunks {:?} hold a side of 0", self.chunks));
        }
        let chunk_bytes = self
            .chunks
            .iter()
            .try_fold(self.dtype.size, |n, &side| n.checked_mul(side))
            .filter(|&n| n <= 1 << 31);
        if chunk_bytes.is_none() {
            return Err(format!(
                "its chunks {:?} are larger than 2 GiB",
                self.chunks
            ));
        }
        if self
            .shape
            .iter()
            .try_fold(1usize, |n, &side| n.checked_mul(side))
            .is_none()
        {
            return Err(format!(
                "its shape {:?} holds more elements than memory",
                self.shape
            ));
        }
        Ok(self)
    }

    fn of_v2(
        name: String,
        folder: &Path,
        meta: &Value,
        attributes: JsonMap<String, Value>,
    ) -> std::result::Result<Self, String> {
        let dtype = DataType::of_v2(meta["dtype"].as_str().unwrap_or_default())?;
        if meta["order"] == "F" {
            return Err("its order is F (Fortran), which is not read: write it in C order".into());
        }
        if meta["filters"].as_array().is_some_and(|f| !f.is_empty()) {
            return Err(format!("its filters {} are not read", meta["filters"]));
        }
        let steps = match &meta["compressor"] {
            Value::Null => Vec::new(),
            compressor => vec![match compressor["id"].as_str().unwrap_or_default() {
                "blosc" => Step::Blosc,
                "zstd" => Step::Zstd,
                "zlib" => Step::Zlib,
                "gzip" => Step::Gzip,
                "lz4" => Step::Lz4,
                other => return Err(format!("its compressor '{other}' is not read")),
            }],
        };
        let dimensions = names(attributes.get("_ARRAY_DIMENSIONS").unwrap_or(&Value::Null));
        Ok(Array {
            name,
            folder: folder.to_path_buf(),
            shape: sizes(&meta["shape"]).ok_or("its shape is not a list of sizes")?,
            chunks: sizes(&meta["chunks"]).ok_or("its chunks are not a list of sizes")?,
            dtype,
            steps,
            shard: None,
            fill: number(&meta["fill_value"], Some(dtype)),
            key_prefix: "",
            separator: meta["dimension_separator"]
                .as_str()
                .unwrap_or(".")
                .to_string(),
            dimensions,
            attributes,
            version: 2,
        })
    }

    fn of_v3(name: String, folder: &Path, meta: &Value) -> std::result::Result<Self, String> {
        let mut dtype = DataType::of_v3(meta["data_type"].as_str().unwrap_or_default())?;
        if meta["chunk_grid"]["name"] != "regular" {
            return Err(format!(
                "its chunk grid {} is not regular",
                meta["chunk_grid"]["name"]
            ));
        }
        let (steps, shard) = codecs(&meta["codecs"], &mut dtype, true)?;
        let encoding = &meta["chunk_key_encoding"];
        let v2_keys = encoding["name"] == "v2";
        let separator = encoding["configuration"]["separator"]
            .as_str()
            .unwrap_or(if v2_keys { "." } else { "/" })
            .to_string();
        let attributes = meta["attributes"].as_object().cloned().unwrap_or_default();
        Ok(Array {
            name,
            folder: folder.to_path_buf(),
            shape: sizes(&meta["shape"]).ok_or("its shape is not a list of sizes")?,
            chunks: sizes(&meta["chunk_grid"]["configuration"]["chunk_shape"])
                .ok_or("its chunk_shape is not a list of sizes")?,
            dtype,
            steps,
            shard,
            fill: number(&meta["fill_value"], Some(dtype)),
            key_prefix: if v2_keys { "" } else { "c" },
            separator,
            dimensions: names(&meta["dimension_names"]),
            attributes,
            version: 3,
        })
    }

    fn attribute(&self, key: &str) -> Option<&Value> {
        self.attributes.get(key)
    }

    fn text(&self, key: &str) -> Option<&str> {
        self.attribute(key).and_then(Value::as_str)
    }

    /// The file of the chunk at grid indices `at`.
    fn chunk_path(&self, at: &[usize]) -> PathBuf {
        let indices: Vec<String> = at.iter().map(usize::to_string).collect();
        let key = if self.key_prefix.is_empty() {
            indices.join(&self.separator)
        } else {
            std::iter::once(self.key_prefix.to_string())
                .chain(indices)
                .collect::<Vec<_>>()
                .join(&self.separator)
        };
        self.folder.join(key)
    }

    /// The chunk's stored bytes decoded to its elements' bytes.
    fn decode(
        &self,
        path: &Path,
        mut bytes: Vec<u8>,
        steps: &[Step],
        size: usize,
        exact: bool,
    ) -> Result<Vec<u8>> {
        let problem = |e: String| Error::input(path, format!("chunk cannot be decoded: {e}"));
        for step in steps {
            bytes = match step {
                Step::Crc32c => {
                    let keep = bytes
                        .len()
                        .checked_sub(4)
                        .ok_or_else(|| problem("no checksum".into()))?;
                    bytes.truncate(keep);
                    bytes
                }
                Step::Blosc => blosc::decompress(&bytes, size).map_err(problem)?,
                Step::Zstd => {
                    zstd::bulk::decompress(&bytes, size).map_err(|e| problem(e.to_string()))?
                }
                Step::Zlib => {
                    inflate(flate2::read::ZlibDecoder::new(&bytes[..]), size).map_err(problem)?
                }
                Step::Gzip => {
                    inflate(flate2::read::GzDecoder::new(&bytes[..]), size).map_err(problem)?
                }
                Step::Lz4 => {
                    let (head, block) = bytes
                        .split_at_checked(4)
                        .ok_or_else(|| problem("no size".into()))?;
                    let stated = i32::from_le_bytes(head.try_into().expect("four bytes"));
                    if usize::try_from(stated).map_or(true, |s| s > size) {
                        return Err(problem(format!(
                            "LZ4 size {stated} where the chunk holds {size}"
                        )));
                    }
                    lz4::block::decompress(block, Some(stated))
                        .map_err(|e| problem(e.to_string()))?
                }
            };
        }
        if exact && bytes.len() != size {
            return Err(problem(format!(
                "it holds {} bytes where a chunk of {}-byte elements holds {size}",
                bytes.len(),
                self.dtype.size
            )));
        }
        Ok(bytes)
    }

    /// The inner chunks of the shard whose (decoded) bytes are `shard`, each decoded,
    /// with its first element's indices; `origin` is the shard's.
    fn unshard(
        &self,
        path: &Path,
        shard: &[u8],
        layout: &Shard,
        origin: &[usize],
    ) -> Result<Vec<(Vec<usize>, Vec<u8>)>> {
        let problem = |e: String| Error::input(path, format!("shard cannot be read: {e}"));
        if layout.inner.len() != self.chunks.len()
            || layout
                .inner
                .iter()
                .zip(&self.chunks)
                .any(|(&i, &c)| i == 0 || c % i != 0)
        {
            return Err(problem(format!(
                "its inner chunks {:?} do not divide its shards {:?}",
                layout.inner, self.chunks
            )));
        }
        let per_side: Vec<usize> = self
            .chunks
            .iter()
            .zip(&layout.inner)
            .map(|(c, i)| c / i)
            .collect();
        let count: usize = per_side.iter().product();
        let index_bytes = 16 * count + if layout.index_checksum { 4 } else { 0 };
        let index = if layout.index_at_end {
            shard
                .len()
                .checked_sub(index_bytes)
                .map(|at| &shard[at..at + 16 * count])
        } else {
            shard.get(..16 * count)
        }
        .ok_or_else(|| {
            problem(format!(
                "{} bytes hold no index of {count} chunks",
                shard.len()
            ))
        })?;
        let inner_size = layout.inner.iter().product::<usize>() * self.dtype.size;
        let word =
            |at: usize| u64::from_le_bytes(index[at..at + 8].try_into().expect("eight bytes"));
        let mut pieces = Vec::new();
        for i in 0..count {
            let (offset, length) = (word(16 * i), word(16 * i + 8));
            if offset == u64::MAX && length == u64::MAX {
                continue;
            }
            let stored = usize::try_from(offset)
                .ok()
                .zip(usize::try_from(length).ok())
                .and_then(|(o, n)| shard.get(o..o.checked_add(n)?))
                .ok_or_else(|| {
                    problem(format!("its chunk {i} lies past its {} bytes", shard.len()))
                })?;
            let bytes = self.decode(path, stored.to_vec(), &layout.steps, inner_size, true)?;
            let mut rest = i;
            let mut at = vec![0; per_side.len()];
            for d in (0..per_side.len()).rev() {
                at[d] = origin[d] + (rest % per_side[d]) * layout.inner[d];
                rest /= per_side[d];
            }
            pieces.push((at, bytes));
        }
        Ok(pieces)
    }

    /// Every element, in C order, through `convert` (missing chunks hold the fill
    /// value). Chunks are decoded in parallel, then laid out a run along x at a time.
    fn values<T: Copy + Send>(&self, convert: impl Fn(f64) -> T + Sync) -> Result<Vec<T>> {
        let count: usize = self.shape.iter().product();
        let mut out = vec![convert(self.fill.unwrap_or(0.0)); count];
        let rank = self.shape.len();
        if rank == 0 {
            return Ok(out);
        }
        let grid: Vec<usize> = self
            .shape
            .iter()
            .zip(&self.chunks)
            .map(|(&n, &c)| n.div_ceil(c.max(1)))
            .collect();
        let index_of = |mut flat: usize, extents: &[usize]| {
            let mut at = vec![0; extents.len()];
            for d in (0..extents.len()).rev() {
                at[d] = flat % extents[d];
                flat /= extents[d];
            }
            at
        };
        let chunk_count: usize = grid.iter().product();
        let chunk_elements: usize = self.chunks.iter().product();
        let size = self.dtype.size;
        let pieces: Vec<Vec<(Vec<usize>, Vec<u8>)>> = (0..chunk_count)
            .into_par_iter()
            .map(|flat| {
                let at = index_of(flat, &grid);
                let path = self.chunk_path(&at);
                let Ok(stored) = std::fs::read(&path) else {
                    return Ok(Vec::new());
                };
                let origin: Vec<usize> = at.iter().zip(&self.chunks).map(|(a, c)| a * c).collect();
                match &self.shard {
                    None => {
                        let bytes =
                            self.decode(&path, stored, &self.steps, chunk_elements * size, true)?;
                        Ok(vec![(origin, bytes)])
                    }
                    Some(layout) => {
                        // A shard: its chunks (compressed, perhaps somewhat larger) and index.
                        let most = 2 * chunk_elements * size + 16 * chunk_elements + 1024;
                        let shard = self.decode(&path, stored, &self.steps, most, false)?;
                        self.unshard(&path, &shard, layout, &origin)
                    }
                }
            })
            .collect::<Result<_>>()?;
        let piece = self.shard.as_ref().map_or(&self.chunks, |s| &s.inner);
        let run = piece[rank - 1];
        let rows_per_piece: usize = piece[..rank - 1].iter().product();
        for (origin, bytes) in pieces.into_iter().flatten() {
            let length = run.min(self.shape[rank - 1].saturating_sub(origin[rank - 1]));
            for row in 0..rows_per_piece {
                let within = index_of(row, &piece[..rank - 1]);
                let mut start = 0;
                let mut inside = true;
                for d in 0..rank - 1 {
                    let position = origin[d] + within[d];
                    inside &= position < self.shape[d];
                    start = start * self.shape[d] + position;
                }
                if !inside {
                    continue;
                }
                let start = start * self.shape[rank - 1] + origin[rank - 1];
                let source = &bytes[row * run * size..(row * run + length) * size];
                self.dtype
                    .convert_run(source, &mut out[start..start + length], &convert);
            }
        }
        Ok(out)
    }
}

fn inflate(mut reader: impl std::io::Read, size: usize) -> std::result::Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(size);
    std::io::Read::read_to_end(
        &mut std::io::Read::take(&mut reader, size as u64 + 1),
        &mut out,
    )
    .map_err(|e| e.to_string())?;
    Ok(out)
}

/// A JSON list of sizes.
fn sizes(value: &Value) -> Option<Vec<usize>> {
    value
        .as_array()?
        .iter()
        .map(|v| v.as_u64().and_then(|n| usize::try_from(n).ok()))
        .collect()
}

/// A JSON list of names (null entries empty).
fn names(value: &Value) -> Vec<String> {
    value
        .as_array()
        .map(|list| {
            list.iter()
                .map(|v| v.as_str().unwrap_or_default().to_string())
                .collect()
        })
        .unwrap_or_default()
}

/// The arrays of the store at `path`: its own, or those of its member folders, by name.
fn arrays(path: &Path) -> Result<Vec<Array>> {
    if let Some(array) = Array::open(path)? {
        return Ok(vec![array]);
    }
    let mut folders: Vec<PathBuf> = std::fs::read_dir(path)
        .map_err(|e| Error::input(path, format!("its folder cannot be listed: {e}")))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    folders.sort();
    let mut found = Vec::new();
    for folder in folders {
        if let Some(array) = Array::open(&folder)? {
            found.push(array);
        }
    }
    Ok(found)
}

/// Whether coordinate array `array` counts in degrees.
fn in_degrees(array: &Array) -> bool {
    let units = array.text("units").unwrap_or_default().to_ascii_lowercase();
    let name = array.name.to_ascii_lowercase();
    units.starts_with("degree") || ["lat", "lon", "latitude", "longitude"].contains(&name.as_str())
}

/// The Zarr store at `path` as map `name`, with whether its rows ran from the north.
pub fn read_zarr_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let all = arrays(path)?;
    let coordinate = |dimension: &str, length: usize| {
        all.iter()
            .find(|a| a.name == dimension && a.shape == [length])
    };
    let gridded = |a: &Array| {
        let rank = a.shape.len();
        rank >= 2
            && a.dimensions.len() == rank
            && coordinate(&a.dimensions[rank - 2], a.shape[rank - 2]).is_some()
            && coordinate(&a.dimensions[rank - 1], a.shape[rank - 1]).is_some()
    };
    let first = all.iter().find(|a| gridded(a)).ok_or_else(|| {
        problem(format!(
            "holds no gridded array: none of its {} arrays ({}) has two dimensions with \
             coordinate arrays of their names (as xarray writes x and y, or lat and lon)",
            all.len(),
            all.iter()
                .map(|a| a.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ))
    })?;
    let rank = first.shape.len();
    let (y_name, x_name) = (&first.dimensions[rank - 2], &first.dimensions[rank - 1]);
    let (height, width) = (first.shape[rank - 2], first.shape[rank - 1]);
    let on_grid: Vec<&Array> = all
        .iter()
        .filter(|a| {
            gridded(a)
                && a.dimensions[a.shape.len() - 2..] == [y_name.clone(), x_name.clone()]
                && a.shape[a.shape.len() - 2..] == [height, width]
        })
        .collect();
    let cells = width.saturating_mul(height);
    let layer_count: usize = on_grid
        .iter()
        .map(|a| {
            a.shape[..a.shape.len() - 2]
                .iter()
                .fold(1usize, |n, &side| n.saturating_mul(side))
        })
        .fold(0usize, usize::saturating_add);
    if cells.saturating_mul(layer_count) > MAX_MAP_CELLS {
        return Err(problem(format!(
            "its gridded arrays hold {layer_count} layers of {width} × {height} cells, more \
             than a map may hold: clip it to the site first"
        )));
    }
    let x_array = coordinate(x_name, width).expect("a gridded array's x");
    let y_array = coordinate(y_name, height).expect("a gridded array's y");
    let (mut xs, mut ys) = (x_array.values(|v| v)?, y_array.values(|v| v)?);
    if in_degrees(x_array) {
        unwrap_longitudes(&mut xs);
    }
    for (values, array) in [(&mut xs, x_array), (&mut ys, y_array)] {
        if let Some(factor) = kilometres(array.text("units").map(str::to_string)) {
            values.iter_mut().for_each(|v| *v *= factor);
        }
    }
    let single = |a: &Array| a.dtype.size == 4;
    let x = spacing(&xs, single(x_array), x_name).map_err(problem)?;
    let y = spacing(&ys, single(y_array), y_name).map_err(problem)?;
    if x.step < 0.0 {
        return Err(problem(format!(
            "its {x_name} coordinates run west, which is not read: reverse them (xarray's \
             sortby)"
        )));
    }
    let transform = [
        x.step,
        0.0,
        x.first - x.step / 2.0,
        0.0,
        y.step,
        y.first - y.step / 2.0,
    ];
    let degrees = in_degrees(x_array) && in_degrees(y_array);
    let crs = grid_crs(path, &all, first, degrees).map_err(problem)?;
    let (geo, heights) = georeference(
        path,
        width as u32,
        height as u32,
        Georeferencing::of_grid(transform, &crs.0, crs.1),
    )?;

    let mut layers: Vec<Vec<f32>> = Vec::new();
    let mut descriptions = Vec::new();
    for array in on_grid {
        let nodata = nodata_of(array);
        let scale = array
            .attribute("scale_factor")
            .and_then(|v| number(v, None));
        let offset = array.attribute("add_offset").and_then(|v| number(v, None));
        let values = array.values(|v| {
            if nodata.contains(&v) || v.is_infinite() {
                f32::NAN
            } else {
                (v * scale.unwrap_or(1.0) + offset.unwrap_or(0.0)) as f32
            }
        })?;
        let leading = &array.dimensions[..array.shape.len() - 2];
        let planes = values.len() / cells.max(1);
        if planes == 1 {
            layers.push(values);
        } else {
            layers.extend(values.chunks(cells).map(<[f32]>::to_vec));
        }
        for step in 0..planes {
            descriptions.push(Some(if leading.is_empty() {
                array.name.clone()
            } else {
                format!("{}_{}{step}", array.name, leading.join("_"))
            }));
        }
    }
    let order = FileOrder::rows(y.step < 0.0);
    let samples = Samples {
        width: width as u32,
        height: height as u32,
        bands: layers.len(),
        order,
        heights,
        sample: |band: usize, cell: usize| layers[band][cell],
    };
    let masks = FileMasks {
        descriptions,
        ..FileMasks::default()
    };
    sidecar_bands::map(path, name, geo, samples, &masks)
}

/// The values array `array` marks as nodata: `_FillValue` and `missing_value`, else (in
/// version 2, where xarray writes `_FillValue` there) the array's fill value.
fn nodata_of(array: &Array) -> Vec<f64> {
    let mut values: Vec<f64> = ["_FillValue", "missing_value"]
        .iter()
        .filter_map(|key| array.attribute(key))
        .filter_map(|v| number(v, Some(array.dtype)))
        .collect();
    if values.is_empty() && array.version == 2 {
        values.extend(array.fill);
    }
    values
}

/// The GeoKeys of the grid: the WKT of `array`'s grid mapping, else of its `_CRS`
/// (GDAL's), WGS 84 for coordinates in degrees, else a `.prj` or GDAL sidecar beside
/// the store.
fn grid_crs(
    path: &Path,
    all: &[Array],
    array: &Array,
    degrees: bool,
) -> std::result::Result<(Vec<u16>, String), String> {
    if let Some(mapping) = array.text("grid_mapping") {
        let mapping = mapping.split_whitespace().next().unwrap_or_default();
        let held = all.iter().find(|a| a.name == mapping).ok_or_else(|| {
            format!(
                "its array {} names grid mapping '{mapping}', which the store does not hold",
                array.name
            )
        })?;
        let wkt = held
            .text("crs_wkt")
            .or_else(|| held.text("spatial_ref"))
            .ok_or_else(|| {
                format!("its grid mapping '{mapping}' gives no WKT (crs_wkt or spatial_ref)")
            })?;
        return wkt_geokeys(wkt).ok_or_else(|| {
            format!(
                "its grid mapping '{mapping}' is neither a projected nor a geographic CRS: {wkt}"
            )
        });
    }
    // GDAL's own: the CRS in the array's `_CRS` attribute, as its Zarr driver writes it.
    if let Some(wkt) = array.attribute("_CRS").and_then(|crs| crs["wkt"].as_str()) {
        return wkt_geokeys(wkt).ok_or_else(|| {
            format!(
                "its array {}'s _CRS is neither a projected nor a geographic CRS: {wkt}",
                array.name
            )
        });
    }
    if degrees {
        return Ok((
            named_crs::geokeys(Named::Geographic, "WGS84").unwrap_or_default(),
            String::new(),
        ));
    }
    crs_keys(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_types_of_both_versions() {
        assert_eq!(
            DataType::of_v2("<f4").unwrap(),
            DataType {
                kind: Kind::Float,
                size: 4,
                little: true
            }
        );
        assert_eq!(
            DataType::of_v2(">i2").unwrap(),
            DataType {
                kind: Kind::Signed,
                size: 2,
                little: false
            }
        );
        assert!(DataType::of_v2("<U8").is_err());
        assert_eq!(DataType::of_v3("uint16").unwrap().size, 2);
        let big = DataType {
            kind: Kind::Signed,
            size: 2,
            little: false,
        };
        assert_eq!(big.read(&(-300i16).to_be_bytes()), -300.0);
    }

    #[test]
    fn fill_values_as_zarr_and_xarray_write_them() {
        let f4 = DataType::of_v3("float32").ok();
        assert!(number(&Value::from("NaN"), f4).unwrap().is_nan());
        assert_eq!(number(&Value::from("0x3f800000"), f4), Some(1.0));
        // xarray's base64 of a float64 NaN, and of an int16 -9999.
        assert!(number(&Value::from("AAAAAAAA+H8="), f4).unwrap().is_nan());
        let i2 = DataType::of_v3("int16").ok();
        let encoded = base64::engine::general_purpose::STANDARD.encode((-9999i16).to_le_bytes());
        assert_eq!(number(&Value::from(encoded), i2), Some(-9999.0));
        assert_eq!(number(&Value::from(-9999), i2), Some(-9999.0));
    }

    #[test]
    fn hostile_shapes_and_chunks_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        for (shape, chunks, needle) in [
            ("[4, 4]", "[2]", "do not match"),
            ("[4, 4]", "[0, 2]", "side of 0"),
            ("[4, 4]", "[4294967296, 4294967296]", "2 GiB"),
            (
                "[4294967296, 4294967296, 4294967296]",
                "[1, 1, 1]",
                "more elements",
            ),
        ] {
            let folder = dir.path().join("a");
            std::fs::create_dir_all(&folder).unwrap();
            let meta = format!(
                r#"{{"zarr_format": 2, "shape": {shape}, "chunks": {chunks}, "dtype": "<f4",
                "compressor": null, "fill_value": 0, "order": "C", "filters": null}}"#
            );
            std::fs::write(folder.join(".zarray"), meta).unwrap();
            let error = Array::open(&folder).unwrap_err().to_string();
            assert!(
                error.contains(needle) && error.contains(".zarray"),
                "{error}"
            );
        }
    }

    #[test]
    fn chunk_keys_of_both_versions() {
        let mut array = Array {
            name: "a".into(),
            folder: PathBuf::from("s/a"),
            shape: vec![4, 4],
            chunks: vec![2, 2],
            dtype: DataType::of_v3("uint8").unwrap(),
            steps: Vec::new(),
            shard: None,
            fill: None,
            key_prefix: "c",
            separator: "/".into(),
            dimensions: vec!["y".into(), "x".into()],
            attributes: JsonMap::new(),
            version: 3,
        };
        assert_eq!(array.chunk_path(&[1, 0]), Path::new("s/a/c/1/0"));
        array.key_prefix = "";
        array.separator = ".".into();
        assert_eq!(array.chunk_path(&[1, 0]), Path::new("s/a/1.0"));
    }
}
