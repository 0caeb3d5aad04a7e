//! The layers of a raster whose format keeps little of its bands (PNG, JPEG, JPEG
//! 2000): GDAL keeps their descriptions, units, scales, offsets, nodata values and
//! colour tables in the PAM sidecar (`.aux.xml`), and masks cells by its rules, in
//! their order: a mask over every band the file holds (GDAL's bit mask appended to a
//! JPEG), else a band's nodata value (the sidecar's, else the file's own), else the
//! dataset's `NODATA_VALUES` (a colour: nodata where every band holds its value), else
//! an alpha band (over every band but itself).

use std::path::Path;

use rayon::prelude::*;

use super::FileOrder;
use super::geotiff::metadata::{layer_names, metres_per_unit};
use super::geotiff::{declared_class_bands, pam_bands};
use crate::error::{Error, Result};
use crate::grid::{GeoRef, Layer, Map};

/// What a file itself says of its cells' validity and meaning.
#[derive(Debug, Default, Clone, PartialEq)]
pub(crate) struct FileMasks {
    /// A mask over every band: `true` where a cell holds data.
    pub mask: Option<Vec<bool>>,
    /// Each band's nodata value, where the file gives one (a PNG's transparent grey, a
    /// palette's one clear entry); empty where it gives none.
    pub nodata: Vec<Option<f32>>,
    /// A colour the file marks transparent (an RGB PNG's), one value per band.
    pub nodata_values: Option<Vec<f32>>,
    /// The alpha band.
    pub alpha: Option<usize>,
    /// Whether each band holds class codes (a palette's indices, a thematic layer);
    /// a band past its end does not.
    pub classes: Vec<bool>,
    /// Each band's description in the file itself (an Imagine layer's name, an ENVI
    /// header's band name), which a sidecar listing the band overrides, even with none
    /// (as GDAL reads it); empty where the file gives none.
    pub descriptions: Vec<Option<String>>,
}

/// A raster's samples as its file holds them, rows from the top.
pub(crate) struct Samples<F> {
    pub width: u32,
    pub height: u32,
    pub bands: usize,
    /// The order the file stores its cells in (ours: rows from the south).
    pub order: FileOrder,
    /// Metres per unit of the heights (the CRS's vertical unit), for bands whose
    /// sidecar names no unit of length.
    pub heights: f64,
    /// The sample of band `b` at cell `i` of the file (row by row from its top).
    pub sample: F,
}

/// The raster at `path` as map `name` on `geo`, its layers as [`layers`] gives them,
/// with the order the file stored its cells in.
pub(crate) fn map<F>(
    path: &Path,
    name: &str,
    geo: GeoRef,
    raster: Samples<F>,
    file: &FileMasks,
) -> Result<(Map, FileOrder)>
where
    F: Fn(usize, usize) -> f32 + Sync,
{
    let order = raster.order;
    let layers = layers(path, raster, file)?;
    let map = Map {
        name: name.to_string(),
        geo,
        layers,
    };
    Ok((map, order))
}

/// The layers of the raster at `path`: named, scaled and masked as its sidecar and
/// `file` say; an error names the sidecar where it is malformed, and the file where
/// every cell is nodata.
fn layers<F>(path: &Path, raster: Samples<F>, file: &FileMasks) -> Result<Vec<Layer>>
where
    F: Fn(usize, usize) -> f32 + Sync,
{
    let problem = |message: String| Error::input(path, message);
    let Samples {
        width,
        height,
        bands,
        order,
        heights,
        sample,
    } = raster;
    let sidecar = pam_bands(path, bands).map_err(problem)?;
    let declared = declared_class_bands(path);
    let mut metadata = sidecar.metadata.clone();
    for ((band, own), listed) in metadata
        .iter_mut()
        .zip(&file.descriptions)
        .zip(&sidecar.listed)
    {
        if !listed {
            band.description.clone_from(own);
        }
    }
    let names = layer_names(&metadata);
    let nodata: Vec<Option<f32>> = (0..bands)
        .map(|b| {
            let own = file.nodata.get(b).copied().flatten();
            sidecar.nodata[b].map(|n| n as f32).or(own)
        })
        .collect();
    let nodata_values: Option<Vec<f32>> = sidecar
        .nodata_values
        .as_ref()
        .map(|values| values.iter().map(|&v| v as f32).collect())
        .or_else(|| file.nodata_values.clone());
    // Whether band `band`'s cell `cell`, of sample `v`, holds no data.
    let is_masked = |band: usize, cell: usize, v: f32| match (&file.mask, nodata[band]) {
        (Some(mask), _) => !mask[cell],
        (None, Some(n)) => v == n || (n.is_nan() && v.is_nan()),
        (None, None) => match &nodata_values {
            Some(values) => (0..bands).all(|b| sample(b, cell) == values[b]),
            None => file
                .alpha
                .is_some_and(|a| a != band && sample(a, cell) == 0.0),
        },
    };
    let row = width as usize;
    let layers: Vec<Layer> = (0..bands)
        .map(|band| {
            let metadata = &sidecar.metadata[band];
            let heights = metadata
                .unit
                .as_deref()
                .and_then(metres_per_unit)
                .unwrap_or(heights);
            let identity = metadata.scale == 1.0 && metadata.offset == 0.0 && heights == 1.0;
            let physical = |v: f32| {
                if identity {
                    // As the sum below gives it: -0 as +0.
                    v + 0.0
                } else {
                    ((f64::from(v) * metadata.scale + metadata.offset) * heights) as f32
                }
            };
            let mut values = vec![0f32; row * height as usize];
            values.par_chunks_mut(row).enumerate().for_each(|(r, out)| {
                for (c, value) in out.iter_mut().enumerate() {
                    let (file_row, file_col) = order.file_cell(r, c, row, height as usize);
                    let cell = file_row * row + file_col;
                    let v = sample(band, cell);
                    *value = if is_masked(band, cell, v) {
                        f32::NAN
                    } else {
                        physical(v)
                    };
                }
            });
            let layer = Layer::new(names[band].clone(), values);
            if file.classes.get(band) == Some(&true) || declared.contains(&band) {
                layer.declared_classes()
            } else {
                layer
            }
        })
        .collect();
    if layers.iter().all(|l| l.values.iter().all(|v| v.is_nan())) {
        return Err(problem(
            "every cell of every band is nodata (masked, transparent or its nodata value)".into(),
        ));
    }
    Ok(layers)
}
