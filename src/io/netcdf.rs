//! netCDF rasters (`.nc`, `.nc4`, GMT's `.grd`): classic (CDF-1, -2, -5) and netCDF-4
//! (HDF5) files, as GEBCO and ETOPO bathymetry, GMT grids, climate reanalyses and
//! GDAL's and xarray's `to_netcdf` hand them out. The container is decoded by the
//! `netcdf-reader` crate; this module reads the CF conventions on top, as GDAL's netCDF
//! driver does:
//!
//! - the gridded variables are those of two or more dimensions that are neither
//!   coordinates nor named by another's `bounds`, `coordinates` or `grid_mapping`; the
//!   first whose last two dimensions have coordinate variables sets the grid (y then
//!   x, or x then y where their axes say so), and every gridded variable on it is read, a layer each (more where leading
//!   dimensions such as time or level hold several steps: one per step);
//! - the grid comes from the coordinate variables (cell centres, evenly spaced); y may
//!   run either way and x east or west; projected coordinates in km (Daymet's) are
//!   read in metres and longitudes that wrap past 360° (a 0–360° product cut across
//!   Greenwich) run on, as GDAL reads them;
//! - the CRS from the `grid_mapping` variable's WKT (`crs_wkt`, GDAL's `spatial_ref`),
//!   else its CF parameters (`latitude_longitude`, transverse Mercator, Lambert
//!   conformal conic, polar stereographic and four equal-area mappings); with no grid
//!   mapping, a `crs` attribute as legacy xarray wrote it (a PROJ string or EPSG
//!   code), else WGS 84 for coordinates in degrees, else a `.prj` or GDAL sidecar;
//! - values are masked by `_FillValue`, `missing_value` and the valid range, with
//!   `_Unsigned` honoured, then unpacked by `scale_factor` and `add_offset`, and
//!   lengths in another unit (`units: km`, `ft`) become metres;
//! - a variable with `flag_values` holds classes (CF's categorical data).

use std::path::Path;

use netcdf_reader::masked::MaskParams;
use netcdf_reader::unpack::{SignParams, UnpackParams};
use netcdf_reader::{
    NcFile, NcGroup, NcReadable, NcSliceInfo, NcSliceInfoElem, NcType, NcVariable,
};
use rayon::prelude::*;

mod classic_names;

use super::FileOrder;
use super::MAX_MAP_CELLS;
use super::ascii_grid::crs_keys;
use super::geotiff::metadata::metres_per_unit;
use super::geotiff::{Georeferencing, georeference, wkt_geokeys};
use super::named_crs::{self, Named};
use super::proj_string::{esri_projected_wkt, user_crs_geokeys};
use super::sidecar_bands::{self, FileMasks, Samples};
use crate::error::{Error, Result, open_input, read_input};
use crate::grid::Map;

/// The text of attribute `name`, where it is text.
fn text(var: &NcVariable, name: &str) -> Option<String> {
    var.attribute(name).and_then(|a| a.value.as_string())
}

/// Which horizontal axis a coordinate variable says it is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Axis {
    X,
    Y,
}

/// The axis coordinate variable `var` marks itself as (CF's `axis`, `standard_name`,
/// `units`, else its name), with whether it counts in degrees.
fn axis_of(var: &NcVariable) -> (Option<Axis>, bool) {
    let lower = |name: &str| text(var, name).map(|t| t.trim().to_ascii_lowercase());
    let units = lower("units").unwrap_or_default();
    let standard = lower("standard_name").unwrap_or_default();
    let name = var.name().to_ascii_lowercase();
    let east = units.starts_with("degree") && (units.ends_with("east") || units.ends_with("_e"));
    let north = units.starts_with("degree") && (units.ends_with("north") || units.ends_with("_n"));
    let longitude = east
        || standard == "longitude"
        || (units.is_empty() && ["lon", "long", "longitude"].contains(&name.as_str()));
    let latitude = north
        || standard == "latitude"
        || (units.is_empty() && ["lat", "latitude"].contains(&name.as_str()));
    let axis = match lower("axis").as_deref() {
        Some("x") => Some(Axis::X),
        Some("y") => Some(Axis::Y),
        _ if longitude || standard == "projection_x_coordinate" => Some(Axis::X),
        _ if latitude || standard == "projection_y_coordinate" => Some(Axis::Y),
        _ if ["x", "lon", "long", "longitude", "easting"].contains(&name.as_str()) => Some(Axis::X),
        _ if ["y", "lat", "latitude", "northing"].contains(&name.as_str()) => Some(Axis::Y),
        _ => None,
    };
    (axis, longitude || latitude)
}

/// Whether `var` holds numbers a layer can take.
fn is_numeric(var: &NcVariable) -> bool {
    matches!(
        var.dtype(),
        NcType::Byte
            | NcType::UByte
            | NcType::Short
            | NcType::UShort
            | NcType::Int
            | NcType::UInt
            | NcType::Int64
            | NcType::UInt64
            | NcType::Float
            | NcType::Double
    )
}

/// The variables of `group` that hold gridded data: two or more numeric dimensions, not
/// a coordinate, not named by another variable as its bounds, auxiliary coordinates or
/// grid mapping.
fn gridded(group: &NcGroup) -> Vec<&NcVariable> {
    let mut named = Vec::new();
    for var in &group.variables {
        for key in ["bounds", "coordinates", "grid_mapping", "climatology"] {
            if let Some(list) = text(var, key) {
                // A grid mapping may be `crs: x y` (CF 1.7's extended form).
                named.extend(
                    list.split_whitespace()
                        .map(|n| n.trim_end_matches(':').to_string()),
                );
            }
        }
    }
    group
        .variables
        .iter()
        .filter(|v| {
            v.ndim() >= 2
                && is_numeric(v)
                && !v.is_coordinate_variable()
                && !named.iter().any(|n| n == v.name())
        })
        .collect()
}

/// One axis of the grid: where its first cell's centre lies and the step between
/// centres (negative where x runs west or y south).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Spacing {
    pub first: f64,
    pub step: f64,
}

/// The even spacing of coordinate values `values` (cell centres); an error says which
/// value breaks it. Single-precision coordinates may stray by their rounding.
pub(super) fn spacing(
    values: &[f64],
    single: bool,
    dimension: &str,
) -> std::result::Result<Spacing, String> {
    let n = values.len();
    if n < 2 {
        return Err(format!(
            "its dimension {dimension} holds {n} coordinate, too few to give a cell size"
        ));
    }
    if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
        return Err(format!("its {dimension} coordinates hold {bad}"));
    }
    let step = (values[n - 1] - values[0]) / (n - 1) as f64;
    let largest = values.iter().fold(0f64, |m, v| m.max(v.abs()));
    let rounding = if single {
        4.0 * f64::from(f32::EPSILON) * largest
    } else {
        0.0
    };
    let tolerance = 0.01 * step.abs() + rounding;
    if step == 0.0 {
        return Err(format!("its {dimension} coordinates do not change"));
    }
    if let Some(i) = (0..n).find(|&i| (values[i] - (values[0] + i as f64 * step)).abs() > tolerance)
    {
        return Err(format!(
            "its {dimension} coordinates are not evenly spaced ({} at index {i}, where an \
             even step of {step} puts {}): regrid it first (gdalwarp)",
            values[i],
            values[0] + i as f64 * step
        ));
    }
    Ok(Spacing {
        first: values[0],
        step,
    })
}

/// Metres per unit of projected coordinates in kilometres (Daymet's Lambert grid: `x`
/// and `y` in `km`), which GDAL reads in metres, the unit of the CRSs they lie in;
/// `None` for any other unit.
pub(super) fn kilometres(units: Option<String>) -> Option<f64> {
    units
        .as_deref()
        .and_then(metres_per_unit)
        .filter(|&factor| factor == 1000.0)
}

/// Longitudes that wrap from 360° to 0° (or 180° to -180°) within the grid, as a
/// region cut across Greenwich from a 0–360° product (CAMS, ERA5) holds them: each a
/// whole turn from where it wrapped, so that they run evenly, and the run a turn west
/// where it starts past 180°, as GDAL reads them (359.55, ..., 0.55 is -0.45 to 0.55).
pub(super) fn unwrap_longitudes(values: &mut [f64]) {
    let mut wrapped = false;
    for i in 1..values.len() {
        let jump = values[i] - values[i - 1];
        if jump.is_finite() && jump.abs() > 180.0 {
            values[i] -= 360.0 * (jump / 360.0).round();
            wrapped = true;
        }
    }
    if wrapped && values[0] >= 180.0 {
        values.iter_mut().for_each(|v| *v -= 360.0);
    }
}

/// The GeoKeys of the grid's CRS: the grid mapping's WKT or `latitude_longitude`;
/// with no grid mapping, the variable's `crs` attribute (legacy xarray's), else WGS 84
/// for coordinates in degrees, else the sidecars'.
fn crs(
    group: &NcGroup,
    var: &NcVariable,
    degrees: bool,
    path: &Path,
) -> std::result::Result<(Vec<u16>, String), String> {
    let mapping_name = text(var, "grid_mapping").map(|m| {
        m.split_whitespace()
            .next()
            .unwrap_or_default()
            .trim_end_matches(':')
            .to_string()
    });
    let Some(mapping_name) = mapping_name.filter(|m| !m.is_empty()) else {
        // xarray's `open_rasterio` (before rioxarray) kept the CRS as the variable's
        // `crs` attribute, a PROJ string or EPSG code, which `to_netcdf` wrote out.
        if let Some(given) = text(var, "crs").filter(|c| !c.trim().is_empty()) {
            return user_crs_geokeys(&given)
                .map_err(|e| format!("its variable {}'s `crs` attribute: {e}", var.name()));
        }
        return if degrees {
            Ok((
                named_crs::geokeys(Named::Geographic, "WGS84").unwrap_or_default(),
                String::new(),
            ))
        } else {
            crs_keys(path)
        };
    };
    let mapping = group.variable(&mapping_name).ok_or_else(|| {
        format!(
            "its variable {} names grid mapping '{mapping_name}', which it does not hold",
            var.name()
        )
    })?;
    if let Some(wkt) = text(mapping, "crs_wkt").or_else(|| text(mapping, "spatial_ref")) {
        return wkt_geokeys(wkt.trim()).ok_or_else(|| {
            format!("its grid mapping {mapping_name}'s WKT is neither a projected nor a geographic CRS: {wkt}")
        });
    }
    let kind = text(mapping, "grid_mapping_name").unwrap_or_default();
    if kind == "latitude_longitude" {
        return Ok((
            named_crs::geokeys(Named::Geographic, "WGS84").unwrap_or_default(),
            String::new(),
        ));
    }
    if let Some(wkt) = cf_projection_wkt(mapping, &kind) {
        return wkt_geokeys(&wkt)
            .ok_or_else(|| format!("its grid mapping {mapping_name} ({kind}) cannot be read"));
    }
    match crs_keys(path)? {
        (keys, ascii) if !keys.is_empty() => Ok((keys, ascii)),
        _ => Err(format!(
            "its grid mapping {mapping_name} ({kind}) gives no WKT (crs_wkt or spatial_ref), \
             is not one whose parameters are read ({}) and no .prj lies beside it: write it \
             with its CRS (gdal_translate -a_srs)",
            CF_PROJECTIONS.join(", ")
        )),
    }
}

/// The CF grid mappings whose parameters alone give the CRS.
const CF_PROJECTIONS: [&str; 7] = [
    "transverse_mercator",
    "lambert_conformal_conic",
    "polar_stereographic",
    "albers_conical_equal_area",
    "lambert_azimuthal_equal_area",
    "lambert_cylindrical_equal_area",
    "sinusoidal",
];

/// The CRS of a CF grid mapping that gives no WKT, from its parameters (CF appendix F),
/// as ESRI WKT 1 (the form an Imagine file's PE string takes); `None` for another
/// mapping. The ellipsoid is `semi_major_axis` with `inverse_flattening` or
/// `semi_minor_axis`, or `earth_radius`; WGS 84 where none is given.
fn cf_projection_wkt(mapping: &NcVariable, kind: &str) -> Option<String> {
    let numbers = |name: &str| {
        mapping
            .attribute(name)
            .and_then(|a| a.value.as_f64_vec())
            .filter(|v| !v.is_empty() && v.iter().all(|x| x.is_finite()))
    };
    let number = |name: &str| numbers(name).map(|v| v[0]);
    let (a, rf) = match (number("semi_major_axis"), number("earth_radius")) {
        (Some(a), _) => {
            let rf = number("inverse_flattening").or_else(|| {
                number("semi_minor_axis").map(|b| if a == b { 0.0 } else { a / (a - b) })
            });
            (a, rf.unwrap_or(298.257223563))
        }
        (None, Some(r)) => (r, 0.0),
        (None, None) => (6378137.0, 298.257223563),
    };
    let origin_latitude = number("latitude_of_projection_origin").unwrap_or(0.0);
    let meridian = number("longitude_of_central_meridian")
        .or_else(|| number("longitude_of_projection_origin"))
        .or_else(|| number("straight_vertical_longitude_from_pole"))
        .unwrap_or(0.0);
    let parallels = numbers("standard_parallel").unwrap_or_default();
    let first = parallels.first().copied();
    let second = parallels.get(1).copied().or(first);
    let (projection, parameters): (&str, Vec<(&str, f64)>) = match kind {
        "transverse_mercator" => (
            "Transverse_Mercator",
            vec![
                ("Central_Meridian", meridian),
                (
                    "Scale_Factor",
                    number("scale_factor_at_central_meridian").unwrap_or(1.0),
                ),
                ("Latitude_Of_Origin", origin_latitude),
            ],
        ),
        "lambert_conformal_conic" => (
            "Lambert_Conformal_Conic",
            vec![
                ("Standard_Parallel_1", first?),
                ("Standard_Parallel_2", second?),
                ("Central_Meridian", meridian),
                ("Scale_Factor", 1.0),
                ("Latitude_Of_Origin", origin_latitude),
            ],
        ),
        "polar_stereographic" => {
            // True scale at the standard parallel, or where the scale at the pole puts
            // it (on the sphere, k0 = (1 + sin φ) / 2).
            let true_scale = first.unwrap_or_else(|| {
                let k0 = number("scale_factor_at_projection_origin").unwrap_or(1.0);
                (2.0 * k0 - 1.0).clamp(-1.0, 1.0).asin().to_degrees() * origin_latitude.signum()
            });
            let pole = if origin_latitude < 0.0 {
                "South"
            } else {
                "North"
            };
            (
                if pole == "South" {
                    "Stereographic_South_Pole"
                } else {
                    "Stereographic_North_Pole"
                },
                vec![
                    ("Central_Meridian", meridian),
                    ("Standard_Parallel_1", true_scale),
                ],
            )
        }
        "albers_conical_equal_area" => (
            "Albers",
            vec![
                ("Central_Meridian", meridian),
                ("Standard_Parallel_1", first?),
                ("Standard_Parallel_2", second?),
                ("Latitude_Of_Origin", origin_latitude),
            ],
        ),
        "lambert_azimuthal_equal_area" => (
            "Lambert_Azimuthal_Equal_Area",
            vec![
                ("Central_Meridian", meridian),
                ("Latitude_Of_Origin", origin_latitude),
            ],
        ),
        "lambert_cylindrical_equal_area" => (
            "Cylindrical_Equal_Area",
            vec![
                ("Central_Meridian", meridian),
                ("Standard_Parallel_1", first.unwrap_or(0.0)),
            ],
        ),
        "sinusoidal" => ("Sinusoidal", vec![("Central_Meridian", meridian)]),
        _ => return None,
    };
    Some(esri_projected_wkt(
        kind,
        (a, rf),
        projection,
        [
            number("false_easting").unwrap_or(0.0),
            number("false_northing").unwrap_or(0.0),
        ],
        &parameters,
        1.0,
    ))
}

/// A gridded variable's layers: one per step of its leading dimensions.
struct Source<'a> {
    var: &'a NcVariable,
    /// Each band's index along the leading dimensions.
    steps: Vec<Vec<u64>>,
}

impl Source<'_> {
    /// The name of each band: the variable's (none for GDAL's own `BandN`, which has
    /// no name of its own), suffixed by the step of each leading dimension of more
    /// than one.
    fn names(&self) -> Vec<Option<String>> {
        let var = self.var;
        let gdal_numbered =
            text(var, "long_name").is_some_and(|l| l.starts_with("GDAL Band Number"));
        self.steps
            .iter()
            .map(|step| {
                if gdal_numbered {
                    return None;
                }
                let mut name = var.name().to_string();
                for (dim, i) in var.dimensions().iter().zip(step) {
                    if dim.size > 1 {
                        name.push_str(&format!("_{}{i}", dim.name));
                    }
                }
                Some(name)
            })
            .collect()
    }
}

/// Every index along `sizes`, the last varying fastest.
fn steps_of(sizes: &[u64]) -> Vec<Vec<u64>> {
    let mut steps = vec![Vec::new()];
    for &size in sizes {
        steps = steps
            .into_iter()
            .flat_map(|prefix| {
                (0..size).map(move |i| {
                    let mut step = prefix.clone();
                    step.push(i);
                    step
                })
            })
            .collect();
    }
    steps
}

/// The first gridded variable whose last two dimensions have coordinate variables,
/// with those (y, then x); an error says why none has.
fn first_on_a_grid<'a>(
    group: &'a NcGroup,
    candidates: &[&'a NcVariable],
) -> std::result::Result<(&'a NcVariable, &'a NcVariable, &'a NcVariable), String> {
    let coordinate = |dim: &str| group.coordinate_variable(dim).filter(|v| v.ndim() == 1);
    let found = candidates.iter().find_map(|&var| {
        let dims = var.dimensions();
        let n = dims.len();
        Some((
            var,
            coordinate(&dims[n - 2].name)?,
            coordinate(&dims[n - 1].name)?,
        ))
    });
    found.ok_or_else(|| match candidates.first() {
        None => "it holds no gridded variable (none of two or more numeric dimensions that \
                 is not a coordinate)"
            .into(),
        Some(v) => format!(
            "its variable {} has no coordinate variables for its last two dimensions ({}), \
             so its grid is unknown",
            v.name(),
            v.dimensions()
                .iter()
                .map(|d| d.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    })
}

/// The grid of `var`, whose last two dimensions have coordinate variables `y` and `x`.
struct Grid {
    x: Spacing,
    y: Spacing,
    width: usize,
    height: usize,
    /// Whether both coordinates count in degrees of longitude and latitude.
    degrees: bool,
    /// The variable lies (x, y): x its second-last dimension, as NASA's TRMM and
    /// GPM subsets come (`precipitation(lon, lat)`).
    transposed: bool,
}

impl Grid {
    fn of(
        file: &NcFile,
        var: &NcVariable,
        y: &NcVariable,
        x: &NcVariable,
    ) -> std::result::Result<Grid, String> {
        let (mut x, mut y) = (x, y);
        let ((mut x_axis, mut x_degrees), (mut y_axis, mut y_degrees)) = (axis_of(x), axis_of(y));
        let transposed = x_axis == Some(Axis::Y) || y_axis == Some(Axis::X);
        if transposed {
            std::mem::swap(&mut x, &mut y);
            std::mem::swap(&mut x_axis, &mut y_axis);
            std::mem::swap(&mut x_degrees, &mut y_degrees);
        }
        if x_axis == Some(Axis::Y) || y_axis == Some(Axis::X) {
            return Err(format!(
                "its variable {} lies on ({}, {}), both of one axis",
                var.name(),
                y.name(),
                x.name()
            ));
        }
        let axis = |coordinate: &NcVariable,
                    longitude: bool|
         -> std::result::Result<(Spacing, usize), String> {
            // Packed coordinates (integers with a `scale_factor`) unpacked, as CF says.
            let mut values: Vec<f64> = file
                .read_variable_unpacked(coordinate.name())
                .map_err(|e| {
                    format!(
                        "its coordinate variable {} cannot be read: {e}",
                        coordinate.name()
                    )
                })?
                .iter()
                .copied()
                .collect();
            if longitude {
                unwrap_longitudes(&mut values);
            } else if let Some(factor) = kilometres(text(coordinate, "units")) {
                values.iter_mut().for_each(|v| *v *= factor);
            }
            let single = coordinate.dtype() == &NcType::Float;
            Ok((spacing(&values, single, coordinate.name())?, values.len()))
        };
        let ((x, width), (y, height)) = (axis(x, x_degrees)?, axis(y, false)?);
        Ok(Grid {
            x,
            y,
            width,
            height,
            degrees: x_degrees && y_degrees,
            transposed,
        })
    }

    /// GDAL's geotransform for the file's rows in the order they lie, x running east.
    fn transform(&self) -> [f64; 6] {
        let (x, y) = (self.x, self.y);
        let dx = x.step.abs();
        let west_edge = x.first.min(x.first + x.step * (self.width - 1) as f64) - dx / 2.0;
        [dx, 0.0, west_edge, 0.0, y.step, y.first - y.step / 2.0]
    }
}

/// The gridded variables lying on `first`'s last two dimensions, each with its steps.
fn sources<'a>(candidates: &[&'a NcVariable], first: &NcVariable) -> Vec<Source<'a>> {
    let grid = &first.dimensions()[first.ndim() - 2..];
    candidates
        .iter()
        .filter(|v| v.dimensions()[v.ndim() - 2..] == *grid)
        .map(|&var| {
            let leading: Vec<u64> = var.dimensions()[..var.ndim() - 2]
                .iter()
                .map(|d| d.size)
                .collect();
            Source {
                var,
                steps: steps_of(&leading),
            }
        })
        .collect()
}

/// How a variable's stored numbers become a layer's values, in CF's order: the
/// signedness `_Unsigned` declares, then `_FillValue`, `missing_value` and the valid
/// range as nodata, then `scale_factor` and `add_offset`, then lengths in metres.
struct Decode {
    sign: Option<SignParams>,
    mask: Option<MaskParams>,
    unpack: UnpackParams,
    /// Metres per unit of a length (`units: km`); 1 for anything else.
    length: f64,
}

impl Decode {
    fn of(var: &NcVariable) -> Decode {
        Decode {
            sign: SignParams::from_variable(var),
            mask: MaskParams::from_variable(var),
            unpack: UnpackParams::from_variable(var).unwrap_or(UnpackParams {
                scale_factor: 1.0,
                add_offset: 0.0,
            }),
            length: text(var, "units")
                .as_deref()
                .and_then(metres_per_unit)
                .unwrap_or(1.0),
        }
    }

    fn value(&self, stored: f64) -> f32 {
        let v = self.sign.map_or(stored, |sign| sign.reinterpret(stored));
        let masked = self.mask.as_ref().is_some_and(|m| {
            m.fill_value == Some(v)
                || m.missing_values.contains(&v)
                || m.valid_min.is_some_and(|min| v < min)
                || m.valid_max.is_some_and(|max| v > max)
        });
        let physical = (v * self.unpack.scale_factor + self.unpack.add_offset) * self.length;
        if masked || !physical.is_finite() {
            f32::NAN
        } else {
            physical as f32
        }
    }
}

/// A stored sample type, widened to f64 for decoding.
trait Stored: NcReadable + Copy + Send + Sync {
    fn widened(self) -> f64;
}

macro_rules! stored {
    ($($t:ty),*) => {
        $(impl Stored for $t {
            fn widened(self) -> f64 {
                self as f64
            }
        })*
    };
}

stored!(i8, u8, i16, u16, i32, u32, i64, u64, f32, f64);

/// The values of `selection` of `var`, read in its stored type (compressed chunks in
/// parallel) and decoded straight to f32: no f64 copy of a band is ever held.
fn decoded<T: Stored>(
    file: &NcFile,
    var: &NcVariable,
    selection: &NcSliceInfo,
) -> std::result::Result<Vec<f32>, String> {
    let decode = Decode::of(var);
    let values = file
        .read_variable_slice_parallel::<T>(var.name(), selection)
        .map_err(|e| format!("its variable {} cannot be read: {e}", var.name()))?;
    Ok(match values.as_slice() {
        Some(values) => values
            .par_iter()
            .map(|&v| decode.value(v.widened()))
            .collect(),
        None => values.iter().map(|&v| decode.value(v.widened())).collect(),
    })
}

/// One band of a source: the step `step` of its leading dimensions, decoded as
/// [`Decode`] says, row by row as the file holds them.
fn band(
    file: &NcFile,
    var: &NcVariable,
    step: &[u64],
    cells: usize,
) -> std::result::Result<Vec<f32>, String> {
    let whole = || NcSliceInfoElem::Slice {
        start: 0,
        end: u64::MAX,
        step: 1,
    };
    let mut selections: Vec<NcSliceInfoElem> =
        step.iter().map(|&i| NcSliceInfoElem::Index(i)).collect();
    selections.extend([whole(), whole()]);
    let selection = NcSliceInfo { selections };
    let values = match var.dtype() {
        NcType::Byte => decoded::<i8>(file, var, &selection),
        NcType::UByte => decoded::<u8>(file, var, &selection),
        NcType::Short => decoded::<i16>(file, var, &selection),
        NcType::UShort => decoded::<u16>(file, var, &selection),
        NcType::Int => decoded::<i32>(file, var, &selection),
        NcType::UInt => decoded::<u32>(file, var, &selection),
        NcType::Int64 => decoded::<i64>(file, var, &selection),
        NcType::UInt64 => decoded::<u64>(file, var, &selection),
        NcType::Float => decoded::<f32>(file, var, &selection),
        NcType::Double => decoded::<f64>(file, var, &selection),
        other => Err(format!(
            "its variable {} holds {other:?}, not numbers",
            var.name()
        )),
    }?;
    if values.len() != cells {
        return Err(format!(
            "its variable {} read {} values where its grid holds {cells}",
            var.name(),
            values.len()
        ));
    }
    Ok(values)
}

/// The netCDF raster at `path` as map `name`, with whether its rows ran from the north.
pub fn read_netcdf_rows(path: &Path, name: &str) -> Result<(Map, FileOrder)> {
    let problem = |message: String| Error::input(path, message);
    // Mapped, not read: a file is known too large to be a map from its header alone.
    open_input(path)?;
    let file = match NcFile::open(path) {
        // A classic header with a name that is not UTF-8: read with it made UTF-8.
        Err(netcdf_reader::Error::InvalidData(why)) if why.contains("UTF-8") => {
            let mut bytes = read_input(path)?;
            match classic_names::make_names_utf8(&mut bytes) {
                Some(1..) => NcFile::from_vec(bytes),
                _ => Err(netcdf_reader::Error::InvalidData(why)),
            }
        }
        opened => opened,
    };
    let file = file.map_err(|e| {
        problem(match e {
            netcdf_reader::Error::InvalidMagic => "it is not a netCDF file (neither classic \
                CDF nor netCDF-4/HDF5); a .grd is read as GMT writes it, in netCDF, or as \
                Surfer does (DSAA, DSBB, DSRB)"
                .into(),
            e => format!("it cannot be read as netCDF: {e}"),
        })
    })?;
    let group = file
        .root_group()
        .map_err(|e| problem(format!("its groups cannot be read: {e}")))?;
    let candidates = gridded(group);
    let (first, y, x) = first_on_a_grid(group, &candidates).map_err(&problem)?;
    let grid = Grid::of(&file, first, y, x).map_err(&problem)?;
    let (width, height) = (grid.width, grid.height);
    let sources = sources(&candidates, first);
    let bands: usize = sources.iter().map(|s| s.steps.len()).sum();
    if bands == 0 {
        return Err(problem(format!(
            "its variable {} holds no step along its leading dimensions",
            first.name()
        )));
    }
    let cells = width.saturating_mul(height).saturating_mul(bands);
    if cells > MAX_MAP_CELLS {
        return Err(problem(format!(
            "its {bands} layers of {width} × {height} hold {cells} cells, more than the \
             {MAX_MAP_CELLS} a map may hold: clip it to the site first (gdal_translate \
             -projwin, or ncks -d)"
        )));
    }
    let (keys, ascii) = crs(group, first, grid.degrees, path).map_err(&problem)?;
    let (geo, heights) = georeference(
        path,
        width as u32,
        height as u32,
        Georeferencing::of_grid(grid.transform(), &keys, ascii),
    )?;

    let mut values: Vec<Vec<f32>> = Vec::with_capacity(bands);
    let mut masks = FileMasks::default();
    for source in &sources {
        for step in &source.steps {
            values.push(band(&file, source.var, step, width * height).map_err(&problem)?);
            masks
                .classes
                .push(source.var.attribute("flag_values").is_some());
        }
        masks.descriptions.extend(source.names());
    }
    let (west, transposed) = (grid.x.step < 0.0, grid.transposed);
    let samples = Samples {
        width: width as u32,
        height: height as u32,
        bands,
        order: FileOrder::rows(grid.y.step < 0.0),
        heights,
        sample: |band: usize, cell: usize| {
            let (row, mut column) = (cell / width, cell % width);
            if west {
                column = width - 1 - column;
            }
            let stored = if transposed {
                column * height + row
            } else {
                row * width + column
            };
            values[band][stored]
        },
    };
    sidecar_bands::map(path, name, geo, samples, &masks)
}

#[cfg(test)]
mod tests {
    use super::*;
    use netcdf_reader::{NcAttrValue, NcAttribute};

    #[test]
    fn longitudes_wrapping_across_greenwich_run_on() {
        let mut across = [359.75, 359.85, 359.95, 0.05, 0.15];
        unwrap_longitudes(&mut across);
        let expected = [-0.25, -0.15, -0.05, 0.05, 0.15];
        assert!(
            across
                .iter()
                .zip(expected)
                .all(|(a, b)| (a - b).abs() < 1e-9)
        );
        let mut antimeridian = [179.5, -179.5, -178.5];
        unwrap_longitudes(&mut antimeridian);
        assert_eq!(antimeridian, [179.5, 180.5, 181.5]);
        let mut global = [0.5, 90.5, 180.5, 270.5];
        unwrap_longitudes(&mut global);
        assert_eq!(global, [0.5, 90.5, 180.5, 270.5]);
    }

    #[test]
    fn spacing_allows_single_precision_rounding_only() {
        let even: Vec<f64> = (0..3600)
            .map(|i| -180.0 + (i as f64 + 0.5) / 10.0)
            .collect();
        let rounded: Vec<f64> = even.iter().map(|&v| f64::from(v as f32)).collect();
        let spaced = spacing(&rounded, true, "lon").unwrap();
        assert!((spaced.step - 0.1).abs() < 1e-6);
        assert!(spacing(&rounded, false, "lon").is_ok());
        let mut gaussian = even.clone();
        gaussian[100] += 0.02;
        assert!(
            spacing(&gaussian, true, "lon")
                .unwrap_err()
                .contains("index 100")
        );
        assert!(spacing(&[1.0], false, "x").unwrap_err().contains("too few"));
        assert!(
            spacing(&[1.0, 1.0], false, "x")
                .unwrap_err()
                .contains("do not change")
        );
        assert!(spacing(&[1.0, f64::NAN], false, "x").is_err());
    }

    fn mapping(attributes: &[(&str, NcAttrValue)]) -> NcVariable {
        NcVariable {
            name: "crs".into(),
            dimensions: Vec::new(),
            dtype: NcType::Int,
            attributes: attributes
                .iter()
                .map(|(name, value)| NcAttribute {
                    name: name.to_string(),
                    value: value.clone(),
                })
                .collect(),
            data_offset: 0,
            _data_size: 0,
            is_record_var: false,
            record_size: 0,
        }
    }

    #[test]
    fn cf_grid_mappings_become_wkt_the_projections_read() {
        let doubles = |v: &[f64]| NcAttrValue::Doubles(v.to_vec());
        let polar = mapping(&[
            (
                "grid_mapping_name",
                NcAttrValue::Chars("polar_stereographic".into()),
            ),
            ("latitude_of_projection_origin", doubles(&[90.0])),
            ("straight_vertical_longitude_from_pole", doubles(&[-45.0])),
            ("standard_parallel", doubles(&[70.0])),
            ("false_easting", doubles(&[0.0])),
        ]);
        let wkt = cf_projection_wkt(&polar, "polar_stereographic").unwrap();
        assert!(wkt.contains("Stereographic_North_Pole"), "{wkt}");
        assert!(
            wkt.contains("PARAMETER[\"Standard_Parallel_1\",70]"),
            "{wkt}"
        );
        assert!(wkt.contains("PARAMETER[\"Central_Meridian\",-45]"), "{wkt}");
        assert!(wkt_geokeys(&wkt).is_some());
        // Variant A: true scale where the pole's scale puts it (k0 = 1: the pole).
        let at_pole = mapping(&[
            ("latitude_of_projection_origin", doubles(&[-90.0])),
            ("scale_factor_at_projection_origin", doubles(&[1.0])),
        ]);
        let wkt = cf_projection_wkt(&at_pole, "polar_stereographic").unwrap();
        assert!(wkt.contains("Stereographic_South_Pole"), "{wkt}");
        assert!(
            wkt.contains("PARAMETER[\"Standard_Parallel_1\",-90]"),
            "{wkt}"
        );
        // A sphere by its radius; a conic needs its parallels.
        let sphere = mapping(&[
            ("earth_radius", doubles(&[6370000.0])),
            ("standard_parallel", doubles(&[30.0, 60.0])),
        ]);
        let wkt = cf_projection_wkt(&sphere, "lambert_conformal_conic").unwrap();
        assert!(
            wkt.contains("SPHEROID[\"S_lambert_conformal_conic\",6370000,0]"),
            "{wkt}"
        );
        assert!(cf_projection_wkt(&mapping(&[]), "lambert_conformal_conic").is_none());
        assert!(cf_projection_wkt(&mapping(&[]), "albers_conical_equal_area").is_none());
        assert!(cf_projection_wkt(&mapping(&[]), "rotated_latitude_pole").is_none());
        assert!(cf_projection_wkt(&mapping(&[]), "sinusoidal").is_some());
    }

    #[test]
    fn steps_run_the_last_dimension_fastest() {
        assert_eq!(steps_of(&[]), vec![Vec::<u64>::new()]);
        assert_eq!(
            steps_of(&[2, 2]),
            vec![vec![0, 0], vec![0, 1], vec![1, 0], vec![1, 1]]
        );
        assert!(steps_of(&[3, 0]).is_empty());
    }
}
