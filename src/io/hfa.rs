//! ERDAS Imagine rasters (`.img`, GDAL's HFA driver), as the USGS handed out the
//! National Elevation Dataset and NLCD land cover and as GDAL writes them.
//!
//! An Imagine file is a tree of typed nodes whose layouts its own data dictionary
//! describes: each band is an `Eimg_Layer` under the root, its samples in blocks that
//! an `Edms_State` node lists (raw, little-endian, or ESRI GRID run-length compressed),
//! its nodata an `Eimg_NonInitializedValue`, its grid an `Eprj_MapInfo` (the top-left
//! cell's centre and the cell's size) and its CRS an ESRI PE string (`Eprj_MapProjection842`)
//! or, in older files, ERDAS's projection parameters (`Eprj_ProParameters`, read here for
//! geographic and UTM CRSs). Bands are named by their layers, as GDAL describes them, and
//! a thematic layer (land cover) or one with a colour table holds class codes. GDAL's sidecar (`.aux.xml`) adds band
//! metadata as for any raster.
//!
//! Samples past 2 GiB lie in a spill file beside the `.img` (`x.ige`, as NLCD's and
//! GDAL's large files have them), read too. Not read: complex samples, grids given as a
//! polynomial (`MapToPixelXForm`: rotated rasters).

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use rayon::prelude::*;

mod dictionary;

use dictionary::{
    Dictionary, MAX_DEPTH, PixelType, TRUNCATED, Value, decode_object, parse_dictionary, u32_at,
};

use super::FileOrder;
use super::MAX_MAP_CELLS as MAX_CELLS;
use super::ascii_grid::crs_keys;
use super::geotiff::{Georeferencing, georeference, pam_georeference, sidecar, wkt_geokeys};
use super::named_crs::{self, Named};
use super::sidecar_bands::{self, FileMasks, Samples};
use crate::error::{Error, Result, read_input};
use crate::grid::Map;

/// The tag every Imagine file opens with.
const HEADER_TAG: &[u8] = b"EHFA_HEADER_TAG";

/// Whether the file at `path` is an Imagine file (opens with its tag), as GDAL tells one
/// from an ENVI raster of the same name.
pub fn is_imagine(path: &Path) -> bool {
    use std::io::Read;
    let mut tag = [0u8; 15];
    std::fs::File::open(path).is_ok_and(|mut f| f.read_exact(&mut tag).is_ok() && tag == HEADER_TAG)
}
/// The most nodes a file's tree may have: a bound on malformed (cyclic) trees.
const MAX_NODES: usize = 1 << 20;

/// The files reading an Imagine raster depends on: its spill file (`x.ige`, as GDAL and
/// ERDAS name it) and GDAL's sidecar.
pub fn hfa_sidecars(path: &Path) -> Vec<PathBuf> {
    [path.with_extension("ige"), sidecar(path)]
        .into_iter()
        .filter(|f| f.is_file())
        .collect()
}

/// A node of the file's tree.
#[derive(Debug, Clone)]
struct Node {
    name: String,
    kind: String,
    data: usize,
    size: usize,
    children: Vec<Node>,
}

impl Node {
    fn child_of_kind(&self, kind: &str) -> Option<&Node> {
        self.children.iter().find(|c| c.kind == kind)
    }
}

/// The node at `at` and its descendants.
fn read_node(
    bytes: &[u8],
    at: u32,
    depth: usize,
    seen: &mut HashSet<u32>,
) -> std::result::Result<Node, String> {
    if depth > MAX_DEPTH || seen.len() > MAX_NODES || !seen.insert(at) {
        return Err("its node tree loops or nests too deeply".into());
    }
    let entry = bytes
        .get(at as usize..at as usize + 124)
        .ok_or_else(|| format!("a node at byte {at} lies past the end of the file"))?;
    let word = |i: usize| u32_at(entry, i).unwrap_or(0);
    let text = |range: std::ops::Range<usize>| {
        let raw = &entry[range];
        let end = raw.iter().position(|&b| b == 0).unwrap_or(raw.len());
        String::from_utf8_lossy(&raw[..end]).into_owned()
    };
    let mut node = Node {
        name: text(24..88),
        kind: text(88..120),
        data: word(16) as usize,
        size: word(20) as usize,
        children: Vec::new(),
    };
    let mut child = word(12);
    while child != 0 {
        let next = read_node(bytes, child, depth + 1, seen)?;
        child = u32_at(bytes, child as usize).unwrap_or(0);
        node.children.push(next);
    }
    Ok(node)
}

/// An Imagine file: its bytes, dictionary and tree.
struct Imagine {
    bytes: Vec<u8>,
    types: Dictionary,
    root: Node,
}

impl Imagine {
    fn parse(bytes: Vec<u8>) -> std::result::Result<Self, String> {
        if !bytes.starts_with(HEADER_TAG) {
            return Err("is not an ERDAS Imagine file (it does not open with \
                        EHFA_HEADER_TAG), nor an ENVI raster (no ENVI header beside it)"
                .into());
        }
        let header = u32_at(&bytes, 16).ok_or(TRUNCATED)? as usize;
        let root = u32_at(&bytes, header + 8).ok_or(TRUNCATED)?;
        let dictionary = u32_at(&bytes, header + 14).ok_or(TRUNCATED)? as usize;
        let types = parse_dictionary(bytes.get(dictionary..).ok_or(TRUNCATED)?)?;
        let root = read_node(&bytes, root, 0, &mut HashSet::new())?;
        Ok(Imagine { bytes, types, root })
    }

    /// A node's data, decoded by its type.
    fn value(&self, node: &Node) -> std::result::Result<Value, String> {
        self.value_as(node, &node.kind)
    }

    fn value_as(&self, node: &Node, kind: &str) -> std::result::Result<Value, String> {
        let data = node
            .data
            .checked_add(node.size)
            .and_then(|end| self.bytes.get(node.data..end))
            .ok_or_else(|| {
                format!(
                    "the data of node {} lies past the end of the file",
                    node.name
                )
            })?;
        decode_object(&self.types, kind, data, 0)
            .map(|(value, _)| value)
            .map_err(|e| format!("node {} ({kind}): {e}", node.name))
    }
}

/// Where a block's bytes lie (`Edms_VirtualBlockInfo`).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Block {
    offset: usize,
    size: usize,
    valid: bool,
    compressed: bool,
}

/// One band: its layer's name, type, blocks and nodata.
#[derive(Debug, Clone, PartialEq)]
struct Band {
    name: String,
    width: usize,
    height: usize,
    pixel: PixelType,
    block_width: usize,
    block_height: usize,
    /// Whether the layer holds class codes: a thematic layer (land cover), or one with a
    /// colour table or class names (GDAL reads either as a palette band).
    thematic: bool,
    /// Whether the blocks lie in the spill file (`.ige`) rather than the `.img`.
    in_spill: bool,
    blocks: Vec<Block>,
    nodata: Option<f64>,
}

impl Imagine {
    /// The band of `layer`, whose blocks may lie in the file's `spill` (its `.ige`'s bytes).
    fn band(&self, layer: &Node, spill: Option<&[u8]>) -> std::result::Result<Band, String> {
        let value = self.value(layer)?;
        let count = |field: &str| -> std::result::Result<usize, String> {
            value
                .number(field)
                .filter(|n| *n >= 1.0 && *n <= f64::from(u32::MAX))
                .map(|n| n as usize)
                .ok_or_else(|| format!("layer {}: its {field} is not a count", layer.name))
        };
        let type_name = value.text("pixelType").unwrap_or_default();
        let pixel = PixelType::from_name(&type_name)
            .filter(|p| *p != PixelType::Complex)
            .ok_or_else(|| {
                format!(
                    "layer {}: samples of type '{type_name}' are not read (u1 to u32, s8 to \
                     s32, f32 and f64 are)",
                    layer.name
                )
            })?;
        let (width, height) = (count("width")?, count("height")?);
        let (block_width, block_height) = (count("blockWidth")?, count("blockHeight")?);
        let external = layer.child_of_kind("ImgExternalRaster");
        let blocks = match (layer.child_of_kind("Edms_State"), external, spill) {
            (Some(state), ..) => listed_blocks(&self.value(state)?),
            (None, Some(external), Some(spill)) => {
                let block_bytes = block_width
                    .checked_mul(block_height)
                    .and_then(|n| n.checked_mul(pixel.bits()))
                    .map(|bits| bits.div_ceil(8))
                    .ok_or_else(|| format!("layer {}: its blocks are too large", layer.name))?;
                spill_blocks(
                    &self.value(external)?,
                    spill,
                    [width.div_ceil(block_width), height.div_ceil(block_height)],
                    block_bytes,
                )
                .map_err(|e| format!("layer {}: its spill file: {e}", layer.name))?
            }
            (None, Some(_), None) => {
                return Err(format!(
                    "layer {}: its samples lie in a spill file (.ige) that cannot be read",
                    layer.name
                ));
            }
            (None, None, _) => {
                return Err(format!(
                    "layer {}: it has no block list (Edms_State)",
                    layer.name
                ));
            }
        };
        let nodata = layer
            .child_of_kind("Eimg_NonInitializedValue")
            .map(|node| self.value(node))
            .transpose()?
            .and_then(|v| v.numbers("valueBD").first().copied());
        Ok(Band {
            name: layer.name.clone(),
            width,
            height,
            pixel,
            block_width,
            block_height,
            in_spill: external.is_some() && layer.child_of_kind("Edms_State").is_none(),
            thematic: value.text("layerType").as_deref() == Some("thematic")
                || layer.child_of_kind("Edsc_Table").is_some_and(|table| {
                    table
                        .children
                        .iter()
                        .any(|column| matches!(column.name.as_str(), "Red" | "Class_Names"))
                }),
            blocks,
            nodata,
        })
    }
}

/// The blocks an `Edms_State` lists.
fn listed_blocks(state: &Value) -> Vec<Block> {
    match state.get("blockinfo") {
        Some(Value::List(items)) => items
            .iter()
            .map(|info| Block {
                offset: info.number("offset").unwrap_or(0.0) as usize,
                size: info.number("size").unwrap_or(0.0) as usize,
                valid: info.text("logvalid").as_deref() == Some("true"),
                compressed: info.text("compressionType").as_deref() != Some("no compression"),
            })
            .collect(),
        _ => Vec::new(),
    }
}

/// The tag a spill file (`.ige`) opens with.
const SPILL_TAG: &[u8] = b"ERDAS_IMG_EXTERNAL_RASTER";

/// The blocks of a layer in a spill file (`ImgExternalRaster`): raw blocks of
/// `block_bytes`, the layers of a stack interleaved block by block from the data offset,
/// each block valid where its bit is set in the bitmap after the flags offset's 20 bytes
/// (a row of bits for each row of blocks, `across` × `down` blocks).
fn spill_blocks(
    external: &Value,
    spill: &[u8],
    [across, down]: [usize; 2],
    block_bytes: usize,
) -> std::result::Result<Vec<Block>, String> {
    if !spill.starts_with(SPILL_TAG) {
        return Err("it does not open with ERDAS_IMG_EXTERNAL_RASTER".into());
    }
    let wide = |field: &str| -> Option<usize> {
        let words = external.numbers(field);
        let low = *words.first()? as u64;
        let high = words.get(1).copied().unwrap_or(0.0) as u64;
        usize::try_from(high.checked_shl(32)? | low).ok()
    };
    let malformed = || "its block layout overflows memory".to_string();
    let flags = wide("layerStackValidFlagsOffset").ok_or_else(malformed)?;
    let data = wide("layerStackDataOffset").ok_or_else(malformed)?;
    let count = external.number("layerStackCount").unwrap_or(1.0).max(1.0) as usize;
    let index = external.number("layerStackIndex").unwrap_or(0.0).max(0.0) as usize;
    let row_bytes = across.div_ceil(8);
    (0..across.checked_mul(down).ok_or_else(malformed)?)
        .map(|i| {
            let (row, column) = (i / across, i % across);
            let bit = row
                .checked_mul(row_bytes * 8)
                .and_then(|b| b.checked_add(column + 20 * 8))
                .ok_or_else(malformed)?;
            let flag = flags
                .checked_add(bit / 8)
                .and_then(|at| spill.get(at))
                .ok_or("its validity bitmap lies past its end")?;
            let offset = i
                .checked_mul(count)
                .and_then(|k| k.checked_add(index))
                .and_then(|k| k.checked_mul(block_bytes))
                .and_then(|o| o.checked_add(data))
                .ok_or_else(malformed)?;
            Ok(Block {
                offset,
                size: block_bytes,
                valid: (flag >> (bit % 8)) & 1 == 1,
                compressed: false,
            })
        })
        .collect()
}

/// The samples of one block of `n` cells, in order.
fn decode_block(
    bytes: &[u8],
    block: Block,
    pixel: PixelType,
    n: usize,
    fill: f32,
) -> std::result::Result<Vec<f32>, String> {
    if !block.valid {
        return Ok(vec![fill; n]);
    }
    let data = block
        .offset
        .checked_add(block.size)
        .and_then(|end| bytes.get(block.offset..end))
        .ok_or_else(|| {
            format!(
                "a block at byte {} of {} bytes lies past the end of the file",
                block.offset, block.size
            )
        })?;
    if block.compressed {
        return run_length_block(data, pixel, n);
    }
    let bits = pixel.bits();
    if data.len() * 8 < n * bits {
        return Err(format!(
            "a block at byte {} holds {} bytes; its {n} samples need {}",
            block.offset,
            data.len(),
            (n * bits).div_ceil(8)
        ));
    }
    Ok(raw_block(data, pixel, n))
}

/// The `n` samples of a raw block, one loop per sample type.
fn raw_block(data: &[u8], pixel: PixelType, n: usize) -> Vec<f32> {
    let bits = pixel.bits();
    if bits < 8 {
        return (0..n).map(|i| pixel.value(packed(data, i, bits))).collect();
    }
    fn words<const N: usize>(data: &[u8], n: usize) -> impl Iterator<Item = [u8; N]> + '_ {
        data[..n * N]
            .chunks_exact(N)
            .map(|w| w.try_into().unwrap_or([0; N]))
    }
    match pixel {
        PixelType::Unsigned(8) => data[..n].iter().map(|&b| f32::from(b)).collect(),
        PixelType::Signed(8) => data[..n].iter().map(|&b| f32::from(b as i8)).collect(),
        PixelType::Unsigned(16) => words(data, n)
            .map(|w| f32::from(u16::from_le_bytes(w)))
            .collect(),
        PixelType::Signed(16) => words(data, n)
            .map(|w| f32::from(i16::from_le_bytes(w)))
            .collect(),
        PixelType::Unsigned(32) => words(data, n)
            .map(|w| u32::from_le_bytes(w) as f32)
            .collect(),
        PixelType::Signed(32) => words(data, n)
            .map(|w| i32::from_le_bytes(w) as f32)
            .collect(),
        PixelType::Float(32) => words(data, n).map(f32::from_le_bytes).collect(),
        _ => words(data, n)
            .map(|w| f64::from_le_bytes(w) as f32)
            .collect(),
    }
}

/// Sample `i` of 1, 2 or 4 `bits`, packed from each byte's low bits.
fn packed(data: &[u8], i: usize, bits: usize) -> u64 {
    let bit = i * bits;
    u64::from((data[bit / 8] >> (bit % 8)) & ((1u8 << bits) - 1))
}

/// A block in ESRI GRID compression: a minimum, a run count (-1: no runs, every value
/// packed), where the values start, their bits; then the runs' counts (one to four
/// bytes, the first byte's top two bits saying how many) and the values (big-endian
/// where wider than a byte), each added to the minimum.
fn run_length_block(
    data: &[u8],
    pixel: PixelType,
    n: usize,
) -> std::result::Result<Vec<f32>, String> {
    let malformed = || "a compressed block ends before its samples do".to_string();
    let minimum = u32_at(data, 0).ok_or_else(malformed)?;
    let runs = u32_at(data, 4).ok_or_else(malformed)? as i32;
    let values_at = u32_at(data, 8).ok_or_else(malformed)? as usize;
    let bits = usize::from(*data.get(12).ok_or_else(malformed)?);
    if !matches!(bits, 0 | 1 | 2 | 4 | 8 | 16 | 32) || pixel.bits() > 32 {
        return Err(format!(
            "a compressed block of {}-bit samples packs its values in {bits} bits",
            pixel.bits()
        ));
    }
    let value = |values: &[u8], i: usize| -> Option<f32> {
        let raw = match bits {
            0 => 0,
            1 | 2 | 4 => {
                let bit = i * bits;
                u32::from((values.get(bit / 8)? >> (bit % 8)) & ((1u8 << bits) - 1))
            }
            _ => {
                let size = bits / 8;
                let word = values.get(i * size..(i + 1) * size)?;
                word.iter().fold(0u32, |v, &b| (v << 8) | u32::from(b))
            }
        };
        Some(pixel.value(u64::from(raw.wrapping_add(minimum))))
    };
    if runs == -1 {
        let values = data.get(13..).ok_or_else(malformed)?;
        return (0..n)
            .map(|i| value(values, i).ok_or_else(malformed))
            .collect();
    }
    let values = data.get(values_at..).ok_or_else(malformed)?;
    let mut out = Vec::with_capacity(n);
    let mut at = 13;
    for run in 0..runs.max(0) as usize {
        let first = *data.get(at).ok_or_else(malformed)?;
        let extra = usize::from(first >> 6);
        let mut repeat = usize::from(first & 0x3f);
        for k in 1..=extra {
            repeat = (repeat << 8) | usize::from(*data.get(at + k).ok_or_else(malformed)?);
        }
        at += 1 + extra;
        let v = value(values, run).ok_or_else(malformed)?;
        let take = repeat.min(n - out.len());
        out.extend(std::iter::repeat_n(v, take));
    }
    if out.len() < n {
        return Err(format!(
            "a compressed block's runs cover {} of its {n} samples",
            out.len()
        ));
    }
    Ok(out)
}

/// A band's samples, row by row from the top.
fn band_samples(bytes: &[u8], band: &Band) -> std::result::Result<Vec<f32>, String> {
    let (bw, bh) = (band.block_width, band.block_height);
    let across = band.width.div_ceil(bw);
    let down = band.height.div_ceil(bh);
    let too_large = || {
        format!(
            "layer {}: its {} × {} cells are more than can be held",
            band.name, band.width, band.height
        )
    };
    let cells = band.width.checked_mul(band.height).ok_or_else(too_large)?;
    if band.blocks.len() < across.saturating_mul(down) {
        return Err(format!(
            "layer {}: its block list has {} blocks; its {} × {} cells in blocks of {bw} × \
             {bh} need {}",
            band.name,
            band.blocks.len(),
            band.width,
            band.height,
            across * down
        ));
    }
    let block_cells = bw
        .checked_mul(bh)
        .filter(|&n| n <= 1 << 26)
        .ok_or_else(|| {
            format!(
                "layer {}: its blocks of {bw} × {bh} are too large",
                band.name
            )
        })?;
    let mut samples = Vec::new();
    samples.try_reserve_exact(cells).map_err(|_| too_large())?;
    samples.resize(cells, 0f32);
    let fill = band.nodata.unwrap_or(0.0) as f32;
    samples
        .par_chunks_mut(band.width * bh)
        .enumerate()
        .try_for_each(|(down_at, rows)| {
            for across_at in 0..across {
                let block = band.blocks[down_at * across + across_at];
                let decoded = decode_block(bytes, block, band.pixel, block_cells, fill)
                    .map_err(|e| format!("layer {}: {e}", band.name))?;
                let columns = bw.min(band.width - across_at * bw);
                for (r, row) in rows.chunks_mut(band.width).enumerate() {
                    row[across_at * bw..across_at * bw + columns]
                        .copy_from_slice(&decoded[r * bw..r * bw + columns]);
                }
            }
            Ok::<(), String>(())
        })?;
    Ok(samples)
}

/// GDAL's geotransform of a layer's `Eprj_MapInfo`, as ours: the top-left cell's centre
/// less half a cell; rows run south unless the bottom-right centre lies north of it.
fn map_info_transform(info: &Value) -> std::result::Result<[f64; 6], String> {
    let number = |path: &str| {
        info.number(path)
            .filter(|n| n.is_finite())
            .ok_or_else(|| format!("its map information (Map_Info) gives no {path}"))
    };
    let (mut x, mut y) = (number("upperLeftCenter.x")?, number("upperLeftCenter.y")?);
    let (mut width, mut height) = (number("pixelSize.width")?, number("pixelSize.height")?);
    let south_up = number("lowerRightCenter.y")? > y;
    if info.text("units").as_deref() == Some("ds") {
        // Arc seconds, which GDAL reads as degrees.
        for v in [&mut x, &mut y, &mut width, &mut height] {
            *v /= 3600.0;
        }
    }
    let dy = if south_up { height } else { -height };
    Ok([width, 0.0, x - width / 2.0, 0.0, dy, y - dy / 2.0])
}

/// The CRS of a file's ESRI PE string (`Eprj_MapProjection842`, whose MIF object holds a
/// `PE_COORDSYS` in its own small dictionary).
fn pe_string(file: &Imagine, node: &Node) -> std::result::Result<Option<String>, String> {
    let value = file.value(node)?;
    if value.text("projection.type.string").as_deref() != Some("PE_COORDSYS") {
        return Ok(None);
    }
    let dictionary = match value.get("projection.MIFDictionary.string") {
        Some(Value::Bytes(bytes)) => parse_dictionary(bytes)?,
        _ => return Ok(None),
    };
    let Some(Value::Bytes(object)) = value.get("projection.MIFObject") else {
        return Ok(None);
    };
    let (coordinates, _) = decode_object(&dictionary, "PE_COORDSYS", object, 0)?;
    Ok(coordinates
        .text("coordSys.string")
        .filter(|s| !s.is_empty()))
}

/// The EPSG GeoKeys of ERDAS's projection parameters where they name a geographic or a
/// UTM CRS on WGS 84, NAD83 or NAD27; `None` for any other.
fn parameter_keys(file: &Imagine, node: &Node) -> std::result::Result<Option<Vec<u16>>, String> {
    let value = file.value(node)?;
    let datum = match node.child_of_kind("Eprj_Datum") {
        Some(d) => file.value(d)?.text("datumname").unwrap_or_default(),
        None => String::new(),
    };
    let crs = match value.number("proNumber") {
        Some(0.0) => Named::Geographic,
        Some(1.0) => {
            let zone = value.number("proZone").unwrap_or(0.0);
            Named::Utm {
                zone: if (1.0..=60.0).contains(&zone) {
                    zone as u16
                } else {
                    0
                },
                north: value.numbers("proParams").get(3).is_none_or(|&s| s >= 0.0),
            }
        }
        _ => return Ok(None),
    };
    Ok(named_crs::geokeys(crs, &datum))
}

/// The Imagine raster at `path` as map `name`, with whether its rows ran from the north.
pub fn read_hfa_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let file = Imagine::parse(read_input(path)?).map_err(problem)?;
    let layers: Vec<&Node> = file
        .root
        .children
        .iter()
        .filter(|n| n.kind == "Eimg_Layer")
        .collect();
    let Some(&first) = layers.first() else {
        return Err(problem("it holds no raster layer (Eimg_Layer)".into()));
    };
    // Before a spill file of many gigabytes is read: a national product (NLCD's 16
    // billion cells) is clipped first.
    let mut cells = 0usize;
    for layer in &layers {
        let value = file.value(layer).map_err(&problem)?;
        let side = |field: &str| value.number(field).unwrap_or(0.0).max(0.0) as usize;
        cells = cells.saturating_add(side("width").saturating_mul(side("height")));
    }
    if cells > MAX_CELLS {
        return Err(problem(format!(
            "its layers hold {cells} cells, more than the {MAX_CELLS} a map may hold: clip \
             it to the site first (gdal_translate -projwin)"
        )));
    }
    let spill = match layers
        .iter()
        .find_map(|layer| layer.child_of_kind("ImgExternalRaster"))
    {
        Some(external) => {
            let name = file
                .value(external)
                .map_err(&problem)?
                .text("fileName.string")
                .unwrap_or_default();
            let spill = path.with_file_name(&name);
            if name.is_empty() || !spill.is_file() {
                return Err(problem(format!(
                    "its samples lie in a spill file '{name}' that is not beside it"
                )));
            }
            Some(read_input(&spill)?)
        }
        None => None,
    };
    let bands: Vec<Band> = layers
        .iter()
        .map(|layer| file.band(layer, spill.as_deref()))
        .collect::<std::result::Result<_, _>>()
        .map_err(problem)?;
    let (width, height) = (bands[0].width, bands[0].height);
    if let Some(other) = bands
        .iter()
        .find(|b| (b.width, b.height) != (width, height))
    {
        return Err(problem(format!(
            "its layers differ in size: {} is {width} × {height} cells, {} is {} × {}",
            bands[0].name, other.name, other.width, other.height
        )));
    }
    if first.child_of_kind("Efga_Polynomial").is_some()
        || first.children.iter().any(|c| c.name == "MapToPixelXForm")
    {
        return Err(problem(
            "its grid is rotated or warped (a MapToPixelXForm polynomial); only \
             axis-aligned rasters are supported: warp it first (gdalwarp)"
                .into(),
        ));
    }
    let pam = pam_georeference(path).map_err(problem)?;
    let transform = match first.child_of_kind("Eprj_MapInfo") {
        Some(node) => map_info_transform(&file.value(node).map_err(&problem)?).map_err(&problem)?,
        None => pam.transform.ok_or_else(|| {
            problem(
                "no georeference: it has no map information (Map_Info) and no GDAL \
                 sidecar (.aux.xml) gives a grid"
                    .into(),
            )
        })?,
    };
    let pe = match first.child_of_kind("Eprj_MapProjection842") {
        Some(node) => pe_string(&file, node).map_err(&problem)?,
        None => None,
    };
    let (keys, ascii) = match pe {
        Some(wkt) => wkt_geokeys(&wkt).ok_or_else(|| {
            problem(format!(
                "its CRS (PE string) is neither a projected nor a geographic CRS: {wkt}"
            ))
        })?,
        None => match first.child_of_kind("Eprj_ProParameters") {
            Some(node) => match parameter_keys(&file, node).map_err(&problem)? {
                Some(keys) => (keys, String::new()),
                None => crs_keys(path).map_err(&problem)?,
            },
            None => crs_keys(path).map_err(&problem)?,
        },
    };
    let (geo, heights) = georeference(
        path,
        width as u32,
        height as u32,
        Georeferencing::of_grid(transform, &keys, ascii),
    )?;
    let order = FileOrder::of_transform(&transform);
    let values: Vec<Vec<f32>> = bands
        .iter()
        .map(|band| match (&spill, band.in_spill) {
            (Some(spill), true) => band_samples(spill, band),
            _ => band_samples(&file.bytes, band),
        })
        .collect::<std::result::Result<_, _>>()
        .map_err(problem)?;
    let samples = Samples {
        width: width as u32,
        height: height as u32,
        bands: bands.len(),
        order,
        heights,
        sample: |band: usize, cell: usize| {
            let value = values[band][cell];
            // Infinities (a ratio's division by zero) are no measurement: nodata.
            if value.is_infinite() { f32::NAN } else { value }
        },
    };
    let masks = FileMasks {
        nodata: bands.iter().map(|b| b.nodata.map(|n| n as f32)).collect(),
        classes: bands.iter().map(|b| b.thematic).collect(),
        descriptions: bands.iter().map(|b| Some(b.name.clone())).collect(),
        ..FileMasks::default()
    };
    sidecar_bands::map(path, name, geo, samples, &masks)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dictionary types a small file needs, as GDAL writes them.
    const DICTIONARY: &str = "{1:lwidth,1:lheight,1:e3:thematic,athematic,fft of real-valued \
        data,layerType,1:e13:u1,u2,u4,u8,s8,u16,s16,u32,s32,f32,f64,c64,c128,pixelType,\
        1:lblockWidth,1:lblockHeight,}Eimg_Layer,{1:sfileCode,1:Loffset,1:lsize,\
        1:e2:false,true,logvalid,1:e2:no compression,ESRI GRID compression,\
        compressionType,}Edms_VirtualBlockInfo,{1:lnumvirtualblocks,\
        1:lnumobjectsperblock,1:lnextobjectnum,1:e2:no compression,RLC compression,\
        compressionType,0:poEdms_VirtualBlockInfo,blockinfo,1:tmodTime,}Edms_State,\
        {1:dx,1:dy,}Eprj_Coordinate,{1:dwidth,1:dheight,}Eprj_Size,{0:pcproName,\
        1:*oEprj_Coordinate,upperLeftCenter,1:*oEprj_Coordinate,lowerRightCenter,\
        1:*oEprj_Size,pixelSize,0:pcunits,}Eprj_MapInfo,.";

    fn entry(child: u32, next: u32, data: u32, size: usize, name: &str, kind: &str) -> Vec<u8> {
        let mut bytes = Vec::new();
        for word in [next, 0, 0, child, data, size as u32] {
            bytes.extend(word.to_le_bytes());
        }
        let mut text = |s: &str, n: usize| {
            let mut field = s.as_bytes().to_vec();
            field.resize(n, 0);
            bytes.extend(field);
        };
        text(name, 64);
        text(kind, 32);
        bytes.extend([0; 4]);
        bytes
    }

    fn pointer(count: u32) -> [u8; 8] {
        let mut bytes = [0; 8];
        bytes[..4].copy_from_slice(&count.to_le_bytes());
        bytes
    }

    /// A 5 × 3 u8 raster in blocks of 4 × 2 (the second of them run-length compressed),
    /// its top-left cell centred at (100.5, 203.5) with cells of 1 × 2.
    fn small_file() -> Vec<u8> {
        let mut file = HEADER_TAG.to_vec();
        file.push(0);
        file.extend(20u32.to_le_bytes());
        let ehfa_file = file.len();
        file.extend([0; 18]);
        let dictionary = file.len() as u32;
        file.extend(DICTIONARY.as_bytes());
        // Block 0 raw: rows 0-1, columns 0-3; block 1 compressed: rows 0-1, column 4;
        // blocks 2 and 3 raw: row 2.
        let raw = |file: &mut Vec<u8>, values: [u8; 8]| {
            let at = file.len();
            file.extend(values);
            (at, 8, false)
        };
        let block0 = raw(&mut file, [1, 2, 3, 4, 6, 7, 8, 9]);
        let block1 = {
            let at = file.len();
            let mut block = Vec::new();
            block.extend(5u32.to_le_bytes());
            block.extend(2u32.to_le_bytes());
            block.extend(15u32.to_le_bytes());
            block.push(8);
            block.extend([4, 4]);
            block.extend([0, 5]);
            file.extend(&block);
            (at, block.len(), true)
        };
        let block2 = raw(&mut file, [11, 12, 13, 14, 0, 0, 0, 0]);
        let block3 = raw(&mut file, [15, 0, 0, 0, 0, 0, 0, 0]);
        let mut layer = Vec::new();
        for word in [5u32, 3] {
            layer.extend(word.to_le_bytes());
        }
        layer.extend(1u16.to_le_bytes());
        layer.extend(3u16.to_le_bytes());
        for word in [4u32, 2] {
            layer.extend(word.to_le_bytes());
        }
        let mut state = Vec::new();
        for word in [4u32, 8, 0] {
            state.extend(word.to_le_bytes());
        }
        state.extend(0u16.to_le_bytes());
        state.extend(pointer(4));
        for (offset, size, compressed) in [block0, block1, block2, block3] {
            state.extend(0u16.to_le_bytes());
            state.extend((offset as u32).to_le_bytes());
            state.extend((size as u32).to_le_bytes());
            state.extend(1u16.to_le_bytes());
            state.extend(u16::from(compressed).to_le_bytes());
        }
        state.extend([0; 4]);
        let mut info = Vec::new();
        info.extend(pointer(1));
        info.push(0);
        for (x, y) in [(100.5, 203.5), (104.5, 199.5), (1.0, 2.0)] {
            info.extend(pointer(1));
            info.extend(f64::to_le_bytes(x));
            info.extend(f64::to_le_bytes(y));
        }
        info.extend(pointer(7));
        info.extend(b"meters\0");
        let put = |file: &mut Vec<u8>, data: &[u8]| {
            let at = file.len() as u32;
            file.extend(data);
            at
        };
        let layer_at = put(&mut file, &layer);
        let state_at = put(&mut file, &state);
        let info_at = put(&mut file, &info);
        let info_entry = put(
            &mut file,
            &entry(0, 0, info_at, info.len(), "Map_Info", "Eprj_MapInfo"),
        );
        let state_entry = put(
            &mut file,
            &entry(
                0,
                info_entry,
                state_at,
                state.len(),
                "RasterDMS",
                "Edms_State",
            ),
        );
        let layer_entry = put(
            &mut file,
            &entry(
                state_entry,
                0,
                layer_at,
                layer.len(),
                "Layer_1",
                "Eimg_Layer",
            ),
        );
        let root = put(&mut file, &entry(layer_entry, 0, 0, 0, "root", "root"));
        file[ehfa_file + 8..ehfa_file + 12].copy_from_slice(&root.to_le_bytes());
        file[ehfa_file + 14..ehfa_file + 18].copy_from_slice(&dictionary.to_le_bytes());
        file
    }

    #[test]
    fn a_small_file_reads_its_blocks_grid_and_names() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("small.img");
        std::fs::write(&path, small_file()).unwrap();
        let (map, order) = read_hfa_rows(&path, "small").unwrap();
        assert_eq!(order, FileOrder::NORTH_UP);
        assert_eq!((map.geo.width, map.geo.height), (5, 3));
        assert_eq!(map.geo.resolution, 1.0);
        assert_eq!(map.geo.resolution_y, Some(2.0));
        assert_eq!(map.geo.origin, [100.0, 198.5]);
        assert_eq!(map.layers[0].name, "Layer_1");
        // Ours run from the south: row 2 of the file first.
        let expected = [
            11., 12., 13., 14., 15., 6., 7., 8., 9., 10., 1., 2., 3., 4., 5.,
        ];
        assert_eq!(map.layers[0].values, expected);
    }

    #[test]
    fn run_length_blocks_with_and_without_runs() {
        // Counts of one and two bytes, 16-bit values big-endian over a minimum of 100.
        let mut block = Vec::new();
        block.extend(100u32.to_le_bytes());
        block.extend(2u32.to_le_bytes());
        block.extend(16u32.to_le_bytes());
        block.push(16);
        block.extend([0x42, 0x00]);
        block.push(1);
        block.extend([0x01, 0x00, 0x00, 0x07]);
        let values = run_length_block(&block, PixelType::Signed(16), 513).unwrap();
        assert_eq!(values[..512], [356.0; 512]);
        assert_eq!(values[512], 107.0);
        // No runs: 4-bit values packed from each byte's low bits.
        let mut packed = Vec::new();
        packed.extend(1u32.to_le_bytes());
        packed.extend((-1i32).to_le_bytes());
        packed.extend(0u32.to_le_bytes());
        packed.push(4);
        packed.extend([0x21, 0x43]);
        let values = run_length_block(&packed, PixelType::Unsigned(8), 4).unwrap();
        assert_eq!(values, [2.0, 3.0, 4.0, 5.0]);
        // Runs short of the block are refused.
        assert!(run_length_block(&block, PixelType::Signed(16), 600).is_err());
    }

    #[test]
    fn a_national_product_is_refused_before_its_samples_are_read() {
        let mut file = small_file();
        // The layer's data (width, height) is the first blob after the blocks: find it
        // by its 5 and 3.
        let at = file
            .windows(8)
            .position(|w| w == [5, 0, 0, 0, 3, 0, 0, 0])
            .unwrap();
        file[at..at + 8].copy_from_slice(&[0x40, 0x75, 0x02, 0, 0x40, 0x94, 0x01, 0]);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("conus.img");
        std::fs::write(&path, file).unwrap();
        let error = read_hfa_rows(&path, "conus").unwrap_err().to_string();
        assert!(error.contains("clip"), "{error}");
    }

    #[test]
    fn other_files_are_refused_saying_what_they_are_not() {
        let envi = Imagine::parse(vec![0; 100]).err().unwrap();
        assert!(
            envi.contains("ERDAS Imagine") && envi.contains("ENVI"),
            "{envi}"
        );
        let mut cut = small_file();
        cut.truncate(400);
        assert!(Imagine::parse(cut).is_err());
    }

    proptest::proptest! {
        /// Any byte of a small file changed to any value, or the file cut anywhere,
        /// reads or is refused with an error: never a panic.
        #[test]
        fn damaged_files_read_or_are_refused(
            at in 0usize..2000,
            byte in proptest::num::u8::ANY,
            cut in 0usize..2000,
        ) {
            let mut file = small_file();
            let at = at % file.len();
            file[at] = byte;
            file.truncate(cut.max(at + 1).min(file.len()));
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("damaged.img");
            std::fs::write(&path, &file).unwrap();
            let _ = read_hfa_rows(&path, "damaged");
        }
    }
}
