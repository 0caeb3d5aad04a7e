//! JPEG 2000 rasters (`.jp2`), as Sentinel-2's band files come in ESA's SAFE products
//! (10980 × 10980 cells of 10 m, 15-bit reflectances) and as GDAL writes them
//! (JP2OpenJPEG). The codestream (lossless 5/3 or lossy 9/7, any progression, tiles,
//! precincts) is decoded by `rust-j2k`; every component is a band, named, scaled and
//! given its nodata by the PAM sidecar where GDAL wrote them there. The georeference is
//! taken where GDAL takes it: the PAM sidecar (`.jp2.aux.xml`), then the GeoJP2 box (a
//! GeoTIFF of 1 × 1 cells in a `uuid` box, whose tags give the grid and CRS as a
//! GeoTIFF's do), then the GMLJP2 box (a GML `RectifiedGrid`: the first cell's centre,
//! two offset vectors and the CRS as an EPSG URN, in the CRS's axis order, latitude
//! first for a geographic one).

use std::path::Path;

use quick_xml::events::Event;
use quick_xml::reader::Reader;
use rayon::prelude::*;

use super::FileOrder;
use super::geotiff::{Georeferencing, georeference, pam_georeference, tags_georeference};
use super::sidecar_bands::{self, FileMasks, Samples};
use crate::error::{Error, Result, read_input};
use crate::grid::{Map, epsg_crs};

/// The UUID of the GeoJP2 box (a GeoTIFF in a `uuid` box).
const GEOJP2_UUID: [u8; 16] = [
    0xb1, 0x4b, 0xf8, 0xbd, 0x08, 0x3d, 0x4b, 0x43, 0xa5, 0xae, 0x8c, 0xd7, 0xd5, 0xa6, 0xce, 0x03,
];

/// The markers a bare codestream (`.j2k`, `.j2c`) starts with: SOC, then SIZ.
const CODESTREAM_START: [u8; 4] = [0xff, 0x4f, 0xff, 0x51];

/// The JPEG 2000 raster at `path` as map `name`, with whether its rows ran from the
/// north.
pub fn read_jp2_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    let bytes = read_input(path)?;
    let file = parse_file(&bytes).map_err(problem)?;
    let image = decode(file.codestream)
        .map_err(|e| problem(format!("its JPEG 2000 codestream cannot be decoded: {e}")))?;
    let (width, height) = (image.width, image.height);
    let located = locate(path, &file).map_err(problem)?;
    let Some(Located {
        transform,
        keys,
        doubles,
        ascii,
    }) = located
    else {
        return Err(problem(
            "no georeference: no GeoJP2 or GMLJP2 box, and no GDAL sidecar (.aux.xml) \
             beside it"
                .into(),
        ));
    };
    let (geo, heights) = georeference(
        path,
        width,
        height,
        Georeferencing {
            transform,
            keys: &keys,
            doubles,
            ascii,
            pixel_is_point_tags: false,
        },
    )?;
    let order = FileOrder::of_transform(&transform);
    // Bands named, scaled and given nodata by GDAL's sidecar, where there is one.
    let samples = Samples {
        width,
        height,
        bands: image.components.len(),
        order,
        heights,
        sample: |band: usize, cell: usize| image.components[band][cell] as f32,
    };
    let masks = FileMasks {
        alpha: file.alpha.filter(|&a| a < image.components.len()),
        ..FileMasks::default()
    };
    sidecar_bands::map(path, name, geo, samples, &masks)
}

/// A decoded image: its size and each component's samples, row by row.
#[derive(Debug)]
struct Decoded {
    width: u32,
    height: u32,
    components: Vec<Vec<i32>>,
}

/// Decodes a codestream. A tiled one (Sentinel-2's bands are 1024² tiles) is decoded
/// tile by tile in parallel, each tile as a codestream of its own ([`tile_codestream`]):
/// faster on several cores, and within the decoder's limit of 2^26 samples per image,
/// which a 10980² band passes.
fn decode(codestream: &[u8]) -> std::result::Result<Decoded, String> {
    let layout = match Layout::parse(codestream) {
        Ok(layout) if layout.tile_parts.len() > 1 && !layout.packed_headers => layout,
        _ => {
            let image = rust_j2k::decode(codestream).map_err(|e| e.to_string())?;
            let (width, height) = (image.width, image.height);
            let components = image
                .components
                .into_iter()
                .enumerate()
                .map(|(index, c)| {
                    if (c.width, c.height) == (width, height) {
                        Ok(c.samples)
                    } else {
                        Err(subsampled(index, [c.width, c.height], [width, height]))
                    }
                })
                .collect::<std::result::Result<_, _>>()?;
            return Ok(Decoded {
                width,
                height,
                components,
            });
        }
    };
    tracing::debug!(
        "a codestream of {} tile-parts: its tiles decoded in parallel",
        layout.tile_parts.len()
    );
    let [width, height] = [
        layout.image[2] - layout.image[0],
        layout.image[3] - layout.image[1],
    ];
    let tiles: Vec<(u16, [u32; 4], rust_j2k::Image)> = layout
        .tile_indices()
        .into_par_iter()
        .map(|tile| {
            let (bytes, area) = layout.tile_codestream(codestream, tile)?;
            let image = rust_j2k::decode(&bytes).map_err(|e| format!("tile {tile}: {e}"))?;
            Ok((tile, area, image))
        })
        .collect::<std::result::Result<_, String>>()?;
    let count = tiles
        .first()
        .map_or(0, |(_, _, image)| image.components.len());
    let mut components = vec![vec![0i32; width as usize * height as usize]; count];
    for (tile, [x0, y0, x1, y1], image) in &tiles {
        let (w, h) = (x1 - x0, y1 - y0);
        if image.components.len() != count {
            return Err(format!("tile {tile} has another number of components"));
        }
        for (index, (component, out)) in image.components.iter().zip(&mut components).enumerate() {
            if (component.width, component.height) != (w, h) {
                return Err(subsampled(
                    index,
                    [component.width, component.height],
                    [w, h],
                ));
            }
            let (left, top) = (
                (x0 - layout.image[0]) as usize,
                (y0 - layout.image[1]) as usize,
            );
            for (row, samples) in component.samples.chunks_exact(w as usize).enumerate() {
                let start = (top + row) * width as usize + left;
                out[start..start + w as usize].copy_from_slice(samples);
            }
        }
    }
    Ok(Decoded {
        width,
        height,
        components,
    })
}

fn subsampled(index: usize, [w, h]: [u32; 2], [width, height]: [u32; 2]) -> String {
    format!(
        "component {} is {w} × {h} cells, sub-sampled from the image's {width} × {height}: \
         every band of a map has its cells",
        index + 1
    )
}

/// Where a codestream's parts lie (ISO/IEC 15444-1 Annex A): its main header's markers,
/// the SIZ marker's grid, and each tile-part.
struct Layout {
    /// The image area on the reference grid: x0, y0, x1, y1 (XOsiz, YOsiz, Xsiz, Ysiz).
    image: [u32; 4],
    /// The tile size and the tile grid's origin: XTsiz, YTsiz, XTOsiz, YTOsiz.
    tiling: [u32; 4],
    /// The byte range of the SIZ marker segment, and of every other main-header one.
    siz: std::ops::Range<usize>,
    main_markers: Vec<std::ops::Range<usize>>,
    /// Whether the main header packs the packet headers (PPM): they cannot be split.
    packed_headers: bool,
    /// Every tile-part: its tile and its byte range, SOT included.
    tile_parts: Vec<(u16, std::ops::Range<usize>)>,
}

/// Markers of the main header that describe the whole codestream's tile-parts and are
/// left out of a tile's own codestream: TLM, PLM.
const WHOLE_STREAM_MARKERS: [u16; 2] = [0xff55, 0xff57];

impl Layout {
    fn parse(cs: &[u8]) -> std::result::Result<Layout, String> {
        let short = || "the codestream is cut short".to_string();
        let u16_at = |at: usize| -> std::result::Result<u16, String> {
            cs.get(at..at + 2)
                .map(|b| u16::from_be_bytes([b[0], b[1]]))
                .ok_or_else(short)
        };
        let u32_at = |at: usize| -> std::result::Result<u32, String> {
            cs.get(at..at + 4)
                .map(|b| u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
                .ok_or_else(short)
        };
        if !cs.starts_with(&CODESTREAM_START) {
            return Err("the codestream does not start with SOC and SIZ".into());
        }
        let mut at = 2;
        let (mut siz, mut main_markers, mut packed_headers) = (0..0, Vec::new(), false);
        loop {
            let marker = u16_at(at)?;
            if marker == 0xff90 {
                break;
            }
            let end = at + 2 + usize::from(u16_at(at + 2)?);
            if end > cs.len() {
                return Err(short());
            }
            match marker {
                0xff51 => siz = at..end,
                0xff60 => packed_headers = true,
                m if WHOLE_STREAM_MARKERS.contains(&m) => {}
                _ => main_markers.push(at..end),
            }
            at = end;
        }
        // Xsiz follows the marker, its length and Rsiz.
        let s = siz.start + 6;
        let image = [u32_at(s + 8)?, u32_at(s + 12)?, u32_at(s)?, u32_at(s + 4)?];
        let tiling = [
            u32_at(s + 16)?,
            u32_at(s + 20)?,
            u32_at(s + 24)?,
            u32_at(s + 28)?,
        ];
        // SIZ holds 38 bytes before its components; the tile grid starts at or before
        // the image area and its first tile reaches into it (Annex A.5.1).
        let sane = siz.len() >= 38
            && tiling[0] > 0
            && tiling[1] > 0
            && image[0] < image[2]
            && image[1] < image[3]
            && tiling[2] <= image[0]
            && tiling[3] <= image[1]
            && u64::from(tiling[2]) + u64::from(tiling[0]) > u64::from(image[0])
            && u64::from(tiling[3]) + u64::from(tiling[1]) > u64::from(image[1]);
        if !sane {
            return Err("its SIZ marker gives no valid image area and tiles".into());
        }
        let mut tile_parts = Vec::new();
        while u16_at(at)? == 0xff90 {
            let tile = u16_at(at + 4)?;
            let length = u32_at(at + 6)? as usize;
            let end = if length == 0 {
                cs.len().saturating_sub(2)
            } else {
                at + length
            };
            // A tile-part holds its 12-byte SOT marker segment at least.
            if end < at + 12 || end > cs.len() {
                return Err(short());
            }
            tile_parts.push((tile, at..end));
            at = end;
        }
        Ok(Layout {
            image,
            tiling,
            siz,
            main_markers,
            packed_headers,
            tile_parts,
        })
    }

    /// The tiles the codestream has parts of, in order.
    fn tile_indices(&self) -> Vec<u16> {
        let mut tiles: Vec<u16> = self.tile_parts.iter().map(|(t, _)| *t).collect();
        tiles.sort_unstable();
        tiles.dedup();
        tiles
    }

    /// Tile `tile` as a codestream of its own, and its area on the reference grid (x0,
    /// y0, x1, y1): the image area cut to the tile, the tile grid moved to start at the
    /// tile so that it is tile 0, the main header's other markers as they are, and the
    /// tile's parts renumbered. Coordinates stay the reference grid's, so precincts and
    /// code-blocks fall where they fell, and the tile decodes to the same samples.
    fn tile_codestream(
        &self,
        cs: &[u8],
        tile: u16,
    ) -> std::result::Result<(Vec<u8>, [u32; 4]), String> {
        let [xt, yt, xto, yto] = self.tiling;
        let across = (self.image[2] - xto).div_ceil(xt);
        let (tx, ty) = (u32::from(tile) % across, u32::from(tile) / across);
        let outside = || format!("tile {tile} lies outside the image");
        // In u64: a tile number past the grid must not wrap onto the image.
        let (left, top) = (
            u64::from(xto) + u64::from(tx) * u64::from(xt),
            u64::from(yto) + u64::from(ty) * u64::from(yt),
        );
        let clip = |start: u64, size: u32, low: u32, high: u32| {
            let (from, to) = (
                start.max(low.into()),
                (start + u64::from(size)).min(high.into()),
            );
            (from < to).then_some((from as u32, to as u32))
        };
        let (x0, x1) = clip(left, xt, self.image[0], self.image[2]).ok_or_else(outside)?;
        let (y0, y1) = clip(top, yt, self.image[1], self.image[3]).ok_or_else(outside)?;
        let area = [x0, y0, x1, y1];
        let (left, top) = (left as u32, top as u32);
        let mut out = CODESTREAM_START[..2].to_vec();
        let mut siz = cs[self.siz.clone()].to_vec();
        for (offset, value) in [
            (6, area[2]),
            (10, area[3]),
            (14, area[0]),
            (18, area[1]),
            (30, left),
            (34, top),
        ] {
            siz[offset..offset + 4].copy_from_slice(&value.to_be_bytes());
        }
        out.extend(siz);
        for range in &self.main_markers {
            out.extend_from_slice(&cs[range.clone()]);
        }
        for (_, range) in self.tile_parts.iter().filter(|(t, _)| *t == tile) {
            let start = out.len();
            out.extend_from_slice(&cs[range.clone()]);
            // Isot, then Psot, which for a last part of length 0 ran to the EOC.
            out[start + 4..start + 6].copy_from_slice(&0u16.to_be_bytes());
            let length = (range.end - range.start) as u32;
            out[start + 6..start + 10].copy_from_slice(&length.to_be_bytes());
        }
        out.extend_from_slice(&[0xff, 0xd9]);
        Ok((out, area))
    }
}

/// The boxes of a JP2 file that this reader uses.
struct File<'a> {
    codestream: &'a [u8],
    /// The GeoJP2 box's TIFF.
    geojp2: Option<&'a [u8]>,
    /// The GMLJP2 box's XML documents.
    gml: Vec<&'a [u8]>,
    /// The component a channel definition box (`cdef`) marks as opacity: an alpha
    /// band, which masks the others as GDAL reads them.
    alpha: Option<usize>,
}

/// The boxes of a JP2 file (ISO/IEC 15444-1 Annex I), or a bare codestream.
fn parse_file(bytes: &[u8]) -> std::result::Result<File<'_>, String> {
    if bytes.starts_with(&CODESTREAM_START) {
        return Ok(File {
            codestream: bytes,
            geojp2: None,
            gml: Vec::new(),
            alpha: None,
        });
    }
    let top = boxes(bytes)?;
    if top.first().map(|(kind, _)| kind) != Some(b"jP  ") {
        return Err(
            "is not a JPEG 2000 file: it starts with neither the JP2 signature box nor a \
             codestream"
                .into(),
        );
    }
    let mut file = File {
        codestream: &[],
        geojp2: None,
        gml: Vec::new(),
        alpha: None,
    };
    for (kind, payload) in &top {
        match kind {
            b"jp2c" if file.codestream.is_empty() => file.codestream = payload,
            b"uuid" if payload.starts_with(&GEOJP2_UUID) => file.geojp2 = Some(&payload[16..]),
            b"asoc" => collect_xml(payload, &mut file.gml)?,
            b"jp2h" => {
                let header = boxes(payload)?;
                if header.iter().any(|(kind, _)| kind == b"pclr") {
                    return Err(
                        "its components are a palette's indices (a pclr box): write the \
                         raster as a GeoTIFF first (gdal_translate)"
                            .into(),
                    );
                }
                if let Some((_, cdef)) = header.iter().find(|(kind, _)| kind == b"cdef") {
                    file.alpha = opacity_channel(cdef);
                }
            }
            _ => {}
        }
    }
    if file.codestream.is_empty() {
        return Err("has no codestream (jp2c box)".into());
    }
    Ok(file)
}

/// The component a channel definition box (`cdef`: a count, then channel, type and
/// association, each a big-endian u16) marks as opacity (type 1, or 2 premultiplied).
fn opacity_channel(cdef: &[u8]) -> Option<usize> {
    let count = usize::from(u16::from_be_bytes([*cdef.first()?, *cdef.get(1)?]));
    cdef.get(2..2 + 6 * count)?
        .chunks_exact(6)
        .find(|entry| matches!(u16::from_be_bytes([entry[2], entry[3]]), 1 | 2))
        .map(|entry| usize::from(u16::from_be_bytes([entry[0], entry[1]])))
}

/// The `xml ` boxes among the boxes of an association (`asoc`), however deep.
fn collect_xml<'a>(payload: &'a [u8], xml: &mut Vec<&'a [u8]>) -> std::result::Result<(), String> {
    for (kind, inner) in boxes(payload)? {
        match &kind {
            b"xml " => xml.push(inner),
            b"asoc" => collect_xml(inner, xml)?,
            _ => {}
        }
    }
    Ok(())
}

/// A box: its type and its payload.
type JpBox<'a> = ([u8; 4], &'a [u8]);

/// The boxes in `bytes`.
fn boxes(bytes: &[u8]) -> std::result::Result<Vec<JpBox<'_>>, String> {
    let mut out = Vec::new();
    let mut at = 0usize;
    while at < bytes.len() {
        let header = bytes
            .get(at..at + 8)
            .ok_or_else(|| format!("a box at byte {at} is cut short"))?;
        let kind: [u8; 4] = header[4..8].try_into().expect("four bytes");
        let length = u32::from_be_bytes(header[..4].try_into().expect("four bytes")) as u64;
        let (length, start) = match length {
            0 => ((bytes.len() - at) as u64, 8),
            1 => {
                let long = bytes
                    .get(at + 8..at + 16)
                    .ok_or_else(|| format!("a box at byte {at} is cut short"))?;
                (
                    u64::from_be_bytes(long.try_into().expect("eight bytes")),
                    16,
                )
            }
            n => (n, 8),
        };
        let end = usize::try_from(length)
            .ok()
            .and_then(|l| at.checked_add(l))
            .filter(|&end| end <= bytes.len() && end >= at + start)
            .ok_or_else(|| {
                format!(
                    "box '{}' at byte {at} claims {length} bytes, more than the file holds",
                    String::from_utf8_lossy(&kind)
                )
            })?;
        out.push((kind, &bytes[at + start..end]));
        at = end;
    }
    Ok(out)
}

/// A georeference as [`Georeferencing`] takes it, owned.
#[derive(Debug)]
struct Located {
    transform: [f64; 6],
    keys: Vec<u16>,
    doubles: Vec<f64>,
    ascii: String,
}

/// Where the raster lies, from the first of GDAL's sources that gives it: the PAM
/// sidecar, the GeoJP2 box, the GMLJP2 box.
fn locate(path: &Path, file: &File) -> std::result::Result<Option<Located>, String> {
    let pam = pam_georeference(path)?;
    let pam_keys = pam.keys.transpose()?;
    let internal = match file.geojp2 {
        Some(tiff) => tags_georeference(tiff)
            .map_err(|e| format!("its GeoJP2 box: {e}"))?
            .map(|tags| Located {
                transform: tags.transform,
                keys: tags.keys,
                doubles: tags.doubles,
                ascii: tags.ascii,
            }),
        None => None,
    };
    let internal = match internal {
        Some(found) => Some(found),
        None => file
            .gml
            .iter()
            .filter_map(|xml| std::str::from_utf8(xml).ok())
            .find(|xml| xml.contains("RectifiedGrid"))
            .map(|xml| gml_grid(xml).map_err(|e| format!("its GMLJP2 box: {e}")))
            .transpose()?,
    };
    Ok(match (pam.transform, internal) {
        (Some(transform), internal) => Some(Located {
            transform,
            keys: pam_keys
                .clone()
                .or_else(|| internal.as_ref().map(|i| i.keys.clone()))
                .unwrap_or_default(),
            doubles: Vec::new(),
            ascii: pam.citation,
        }),
        (None, Some(mut internal)) => {
            if let Some(keys) = pam_keys {
                internal.keys = keys;
                internal.doubles = Vec::new();
                internal.ascii = pam.citation;
            }
            Some(internal)
        }
        (None, None) => None,
    })
}

/// The grid a GMLJP2 `RectifiedGrid` gives: its origin is the first cell's centre, its
/// offset vectors a step along a row and down a column, in the axis order of its CRS.
fn gml_grid(xml: &str) -> std::result::Result<Located, String> {
    let mut reader = Reader::from_str(xml);
    let (mut origin, mut vectors) = (None, Vec::new());
    // The CRS the origin's point names, else the first any element names.
    let (mut origin_srs, mut any_srs) = (None, None);
    let mut in_origin = false;
    let mut text = String::new();
    let numbers = |text: &str, what: &str| -> std::result::Result<[f64; 2], String> {
        let values: Vec<f64> = text
            .split_whitespace()
            .map(str::parse)
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| format!("its {what} '{}' is not numbers", text.trim()))?;
        values
            .get(..2)
            .map(|v| [v[0], v[1]])
            .ok_or_else(|| format!("its {what} '{}' is not two numbers", text.trim()))
    };
    loop {
        match reader.read_event().map_err(|e| e.to_string())? {
            Event::Eof => break,
            Event::Start(tag) => {
                text.clear();
                in_origin |= tag.local_name().as_ref() == b"origin";
                for attribute in tag.attributes().flatten() {
                    if attribute.key.local_name().as_ref() == b"srsName" {
                        let name = String::from_utf8_lossy(&attribute.value).into_owned();
                        if in_origin {
                            origin_srs.get_or_insert(name.clone());
                        }
                        any_srs.get_or_insert(name);
                    }
                }
            }
            Event::Text(t) => text.push_str(&t.decode().map_err(|e| e.to_string())?),
            Event::End(tag) => {
                match tag.local_name().as_ref() {
                    b"pos" if in_origin && origin.is_none() => {
                        origin = Some(numbers(&text, "origin")?)
                    }
                    b"origin" => in_origin = false,
                    b"offsetVector" => vectors.push(numbers(&text, "offset vector")?),
                    _ => {}
                }
                text.clear();
            }
            _ => {}
        }
    }
    let origin = origin.ok_or("its RectifiedGrid has no origin")?;
    let [along_row, down_column] = vectors[..] else {
        return Err(format!(
            "its RectifiedGrid has {} offset vectors, not 2",
            vectors.len()
        ));
    };
    let srs = origin_srs
        .or(any_srs)
        .ok_or("its RectifiedGrid names no CRS (srsName)")?;
    let code: u16 = srs
        .rsplit([':', '/'])
        .next()
        .and_then(|c| c.trim().parse().ok())
        .filter(|_| srs.to_ascii_uppercase().contains("EPSG"))
        .ok_or_else(|| format!("its CRS '{srs}' is not an EPSG code"))?;
    let crs =
        epsg_crs(code).ok_or_else(|| format!("its CRS EPSG:{code} is not in the registry"))?;
    // A geographic CRS's EPSG axis order is latitude first, as GML gives it.
    let geographic = crs.is_geographic();
    let xy = |[first, second]: [f64; 2]| {
        if geographic {
            [second, first]
        } else {
            [first, second]
        }
    };
    let ([x0, y0], [a, d], [b, e]) = (xy(origin), xy(along_row), xy(down_column));
    let keys = vec![
        1,
        1,
        0,
        2,
        1024,
        0,
        1,
        if geographic { 2 } else { 1 },
        if geographic { 2048 } else { 3072 },
        0,
        1,
        code,
    ];
    Ok(Located {
        transform: [a, b, x0 - (a + b) / 2.0, d, e, y0 - (d + e) / 2.0],
        keys,
        doubles: Vec::new(),
        ascii: String::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn make_box(kind: &[u8; 4], payload: &[u8]) -> Vec<u8> {
        let mut out = ((payload.len() + 8) as u32).to_be_bytes().to_vec();
        out.extend_from_slice(kind);
        out.extend_from_slice(payload);
        out
    }

    #[test]
    fn boxes_are_walked_and_cut_ones_named() {
        let mut file = make_box(b"jP  ", &[0x0d, 0x0a, 0x87, 0x0a]);
        let mut long = 1u32.to_be_bytes().to_vec();
        long.extend_from_slice(b"xml ");
        long.extend_from_slice(&19u64.to_be_bytes());
        long.extend_from_slice(b"<a/>");
        file.extend(&long[..long.len() - 1]);
        file.extend(make_box(b"jp2c", &[1, 2, 3]));
        let found = boxes(&file).unwrap();
        let kinds: Vec<&[u8; 4]> = found.iter().map(|(k, _)| k).collect();
        assert_eq!(kinds, [b"jP  ", b"xml ", b"jp2c"]);
        assert_eq!(found[1].1, b"<a/");
        assert_eq!(found[2].1, [1, 2, 3]);
        let cut = &file[..file.len() - 1];
        let why = boxes(cut).unwrap_err();
        assert!(why.contains("box 'jp2c'"), "{why}");
        let why = parse_file(&make_box(b"ftyp", b"jp2 ")).err().unwrap();
        assert!(why.contains("not a JPEG 2000 file"), "{why}");
    }

    /// A GMLJP2 document as GDAL writes it, in `srs` with `origin` and the vectors.
    fn gml(srs: &str, origin: &str, row: &str, column: &str) -> String {
        format!(
            r#"<gml:FeatureCollection xmlns:gml="http://www.opengis.net/gml">
  <gml:featureMember><gml:FeatureCollection><gml:featureMember>
  <gml:RectifiedGridCoverage dimension="2" gml:id="RGC0001"><gml:rectifiedGridDomain>
  <gml:RectifiedGrid dimension="2">
    <gml:limits><gml:GridEnvelope><gml:low>0 0</gml:low><gml:high>319 239</gml:high></gml:GridEnvelope></gml:limits>
    <gml:axisName>x</gml:axisName><gml:axisName>y</gml:axisName>
    <gml:origin><gml:Point gml:id="P0001" srsName="{srs}"><gml:pos>{origin}</gml:pos></gml:Point></gml:origin>
    <gml:offsetVector srsName="{srs}">{row}</gml:offsetVector>
    <gml:offsetVector srsName="{srs}">{column}</gml:offsetVector>
  </gml:RectifiedGrid></gml:rectifiedGridDomain></gml:RectifiedGridCoverage>
  </gml:featureMember></gml:FeatureCollection></gml:featureMember></gml:FeatureCollection>"#
        )
    }

    #[test]
    fn a_gml_grid_gives_the_first_cells_corner_in_the_crs_axis_order() {
        let utm = gml(
            "urn:ogc:def:crs:EPSG::32632",
            "399965 5099995",
            "10 0",
            "0 -10",
        );
        let grid = gml_grid(&utm).unwrap();
        assert_eq!(grid.transform, [10.0, 0.0, 399960.0, 0.0, -10.0, 5100000.0]);
        assert_eq!(&grid.keys[4..], [1024, 0, 1, 1, 3072, 0, 1, 32632]);
        // EPSG:4326's axes are latitude, then longitude.
        let degrees = gml(
            "http://www.opengis.net/def/crs/EPSG/0/4326",
            "46.99975 7.0005",
            "0 0.001",
            "-0.0005 0",
        );
        let grid = gml_grid(&degrees).unwrap();
        let expected = [0.001, 0.0, 7.0, 0.0, -0.0005, 47.0];
        for (a, b) in grid.transform.iter().zip(expected) {
            assert!((a - b).abs() < 1e-12, "{:?}", grid.transform);
        }
        assert_eq!(&grid.keys[4..], [1024, 0, 1, 2, 2048, 0, 1, 4326]);
        let why = gml_grid(&gml("urn:ogc:def:crs:OGC:1.3:CRS84", "0 0", "1 0", "0 -1"));
        assert!(why.unwrap_err().contains("not an EPSG code"));
        let why = gml_grid(&utm.replace(
            "<gml:offsetVector srsName=\"urn:ogc:def:crs:EPSG::32632\">0 -10</gml:offsetVector>",
            "",
        ));
        assert!(why.unwrap_err().contains("1 offset vectors"));
    }

    /// A codestream's skeleton: SOC, SIZ of one 8-bit component on a `size` image in
    /// `tile` tiles, a COM marker, TLM, and a tile-part of 4 data bytes per `parts` tile.
    fn skeleton(size: [u32; 2], tile: [u32; 2], parts: &[u16]) -> Vec<u8> {
        let mut cs = vec![0xff, 0x4f, 0xff, 0x51, 0, 41, 0, 0];
        for v in [size[0], size[1], 0, 0, tile[0], tile[1], 0, 0] {
            cs.extend(v.to_be_bytes());
        }
        cs.extend([0, 1, 7, 1, 1]);
        cs.extend([0xff, 0x64, 0, 5, 0, 1, b'x']);
        cs.extend([0xff, 0x55, 0, 4, 0, 0]);
        for &t in parts {
            cs.extend([0xff, 0x90, 0, 10]);
            cs.extend(t.to_be_bytes());
            cs.extend(18u32.to_be_bytes());
            cs.extend([0, 1, 0xff, 0x93, 1, 2, 3, 4]);
        }
        cs.extend([0xff, 0xd9]);
        cs
    }

    #[test]
    fn a_tile_becomes_a_codestream_of_its_own_on_the_same_grid() {
        let cs = skeleton([100, 60], [64, 64], &[0, 1]);
        let layout = Layout::parse(&cs).unwrap();
        assert_eq!(layout.image, [0, 0, 100, 60]);
        assert_eq!(layout.tile_indices(), [0, 1]);
        let (tile, area) = layout.tile_codestream(&cs, 1).unwrap();
        assert_eq!(area, [64, 0, 100, 60]);
        let one = Layout::parse(&tile).unwrap();
        // The image area is the tile's; the tile grid starts at it; no TLM is left.
        assert_eq!(one.image, [64, 0, 100, 60]);
        assert_eq!(one.tiling, [64, 64, 64, 0]);
        assert_eq!(one.tile_indices(), [0]);
        assert_eq!(one.main_markers.len(), 1);
        assert!(!tile.windows(2).any(|w| w == [0xff, 0x55]));
        assert!(tile.ends_with(&[1, 2, 3, 4, 0xff, 0xd9]));
        // A tile past the grid, and broken headers, are errors, never panics.
        assert!(layout.tile_codestream(&cs, 9).is_err());
        assert!(layout.tile_codestream(&cs, u16::MAX).is_err());
        let mut short_siz = cs.clone();
        short_siz[5] = 20;
        assert!(Layout::parse(&short_siz).is_err());
        let mut no_tiles = skeleton([100, 60], [0, 64], &[0]);
        assert!(Layout::parse(&no_tiles).is_err());
        no_tiles.truncate(no_tiles.len() - 8);
        assert!(Layout::parse(&no_tiles).is_err());
        for cut in 0..cs.len() {
            let _ = decode(&cs[..cut]);
        }
        assert!(decode(&cs).is_err());
    }

    #[test]
    fn a_channel_definition_names_the_alpha_component() {
        // RGBA: channels 0 to 2 colours (type 0) of red, green and blue, channel 3
        // opacity (type 1) of the whole image.
        let cdef = [
            0, 4, 0, 0, 0, 0, 0, 1, 0, 1, 0, 0, 0, 2, 0, 2, 0, 0, 0, 3, 0, 3, 0, 1, 0, 0,
        ];
        assert_eq!(opacity_channel(&cdef), Some(3));
        assert_eq!(opacity_channel(&[0, 1, 0, 0, 0, 0, 0, 1]), None);
        assert_eq!(opacity_channel(&[0, 9, 0]), None);
    }
}
