//! Georeferenced rasters and paths on them. Depends on nothing else of ours.
//!
//! Conventions (the same as ROS `nav_msgs/OccupancyGrid`): cell (row 0, col 0) is the
//! south-west corner of the map, columns grow with +x (east) and rows with +y (north);
//! `origin` is the world position of that cell's outer corner, `resolution` the cell
//! size in the frame's units (metres, or degrees in a geographic frame). Data are stored
//! row by row. Whatever the frame, features and planners measure in metres per axis
//! ([`GeoRef::cell_metres`]), so cells need not be square.

mod coarsen;
mod demo;
mod epsg;
mod equal_area;
mod geodesy;
mod map;
mod path;
mod points;
mod reproject;
mod resample;
mod world_sphere;

pub use coarsen::{Edges, coarsened, factor_for_cells, factor_for_metres};
pub use demo::{Demonstration, Pose};
pub use epsg::{
    ProjCrs, epsg_crs, epsg_ellipsoid_name, metres_per_epsg_unit, named_ellipsoid_axes,
};
pub use equal_area::{Ellipsoid, EqualArea};
pub use geodesy::{Projection, TRUE_SCALE_TOLERANCE, metres_per_degree};

pub use map::{
    Layer, LayerKind, MAX_CLASSES, MAX_DECLARED_CLASSES, Map, check_map_name, classes_of,
    distinct_integers,
};
pub use path::{CellPath, PathError, is_connected8, rasterize, rasterize_polyline};
pub use points::PointReader;
pub use reproject::Reprojection;
pub use resample::resampled_layers;

use serde::{Deserialize, Serialize};

/// Where a raster lies in the world.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeoRef {
    pub width: u32,
    pub height: u32,
    /// Cell size along x (east) in frame units: metres, degrees of longitude, or a
    /// projected CRS's own unit (feet).
    pub resolution: f64,
    /// Cell size along y (north) in frame units, where it differs from `resolution`
    /// (GeoTIFFs as GDAL writes them are rarely exactly square).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution_y: Option<f64>,
    /// World (x, y) of the outer corner of cell (0, 0).
    pub origin: [f64; 2],
    /// The coordinate frame the origin is given in (e.g. "map").
    pub frame: String,
    /// Frame units are degrees of longitude (x) and latitude (y): a geographic CRS.
    /// Lengths on the ground then come from the latitude (`cell_metres`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub degrees: bool,
    /// The frame is Web Mercator (EPSG:3857): its units are metres only on the
    /// equator, a unit spanning cos φ ground metres at latitude φ (0.77 at 39.6° N).
    /// Lengths on the ground then come from the northing (`cell_metres`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub web_mercator: bool,
    /// Ground metres per frame unit where a projected CRS's unit is not the metre
    /// (0.3048006 for US survey feet, times the scale below where that is far from 1)
    /// or its scale is far from 1 and the reader measured it at the raster's centre: 0.962 for a cell at 60° N in
    /// NSIDC's Arctic grid (EPSG:3413), 1.010 along x and 0.990 along y in Conus Albers
    /// (EPSG:5070) at 37.5° N. Taken for the whole raster, as rasters in these grids
    /// are small beside their scale's variation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ground_scale: Option<GroundScale>,
    /// The CRS as the GeoTIFF it was read from gave it, so that rasters written back
    /// carry it (`io::geotiff::write_geotiff`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tiff_crs: Option<TiffCrs>,
}

/// A GeoTIFF's CRS: its GeoKeys (less the raster type and any vertical CRS) with their
/// double and ASCII parameters, and the ground units (metres, or degrees in a
/// geographic frame) per unit of its coordinates. Kept so that a costmap exported as
/// a GeoTIFF carries the very CRS it was learned on, in that CRS's own units: whether an
/// EPSG code names it or its parameters define it (ESRI's codes, PROJ strings), and
/// whether its coordinates are feet (which the frame keeps) or radians (which the reader
/// turned into degrees).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TiffCrs {
    /// GeoKeyDirectory entries: key, location (0, or the tag holding the value), count,
    /// value or offset.
    pub keys: Vec<[u16; 4]>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub doubles: Vec<f64>,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub ascii: String,
    /// Frame units per unit of the CRS's coordinates: 1 for projected CRSs, whose
    /// coordinates the frame keeps (feet included); 0.9 for a geographic CRS in grads.
    pub frame_units_per_unit: f64,
    /// A PROJ string of a CRS that the keys define by its parameters alone (no EPSG
    /// code, as ArcGIS and some GDAL writers leave them), in the frame's units, so that
    /// poses and rasters in other CRSs can be moved into it ([`Reprojection`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub proj: Option<String>,
}

/// Ground metres per frame unit: one factor for both axes (conformal projections), or
/// one per axis (equal-area ones stretch one axis by what they shrink the other).
/// Stored as a number or as `[x, y]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum GroundScale {
    Uniform(f64),
    PerAxis([f64; 2]),
}

impl GroundScale {
    /// Ground metres per frame unit along x and along y.
    pub fn per_axis(self) -> [f64; 2] {
        match self {
            GroundScale::Uniform(s) => [s; 2],
            GroundScale::PerAxis(scales) => scales,
        }
    }
}

impl GeoRef {
    /// A grid of 1 m cells at the origin of frame "map" (for tests and synthetic data).
    pub fn unit(width: u32, height: u32) -> Self {
        GeoRef {
            width,
            height,
            resolution: 1.0,
            resolution_y: None,
            origin: [0.0, 0.0],
            frame: "map".into(),
            degrees: false,
            web_mercator: false,
            ground_scale: None,
            tiff_crs: None,
        }
    }

    /// Square cells of `resolution` metres with their corner at `origin` in `frame`.
    pub fn square(width: u32, height: u32, resolution: f64, origin: [f64; 2], frame: &str) -> Self {
        GeoRef {
            resolution,
            origin,
            frame: frame.into(),
            ..GeoRef::unit(width, height)
        }
    }

    /// Cell size (x, y) in frame units.
    pub fn cell_size(&self) -> [f64; 2] {
        [
            self.resolution,
            self.resolution_y.unwrap_or(self.resolution),
        ]
    }

    /// Cell size (x, y) in metres on the ground. In a geographic or Web Mercator frame
    /// it is measured at the raster's middle row (rasters spanning many degrees of
    /// latitude are stretched away from it: `scale_variation` says how much; planners,
    /// derivatives, distances and metric blurs use `cell_metres_by_row`).
    pub fn cell_metres(&self) -> [f64; 2] {
        self.cell_metres_at(0.5 * f64::from(self.height))
    }

    /// Whether ground lengths of a frame unit change from row to row (geographic and
    /// Web Mercator frames).
    pub fn varies_by_row(&self) -> bool {
        self.degrees || self.web_mercator
    }

    /// Cell size (x, y) in metres on the ground, row by row: one pair for every row
    /// where the frame's scale changes with latitude, measured at the row's middle, and
    /// one pair for them all elsewhere.
    pub fn cell_metres_by_row(&self) -> Vec<[f64; 2]> {
        if !self.varies_by_row() {
            return vec![self.cell_metres()];
        }
        (0..self.height)
            .map(|r| self.cell_metres_at(f64::from(r) + 0.5))
            .collect()
    }

    /// Cell size (x, y) in ground metres `rows` rows north of the southern edge (where
    /// the frame's scale varies, it is taken there).
    pub fn cell_metres_at(&self, rows: f64) -> [f64; 2] {
        let [sx, sy] = self.cell_size();
        let y = self.origin[1] + rows * sy;
        let [east, north] = if self.degrees {
            geodesy::metres_per_degree(y.clamp(-90.0, 90.0))
        } else if self.web_mercator {
            geodesy::metres_per_web_mercator_unit(y)
        } else {
            self.ground_scale.map_or([1.0; 2], GroundScale::per_axis)
        };
        [sx * east, sy * north]
    }

    /// The latitude of the southern edge and of the northern one, where the frame
    /// knows it (geographic and Web Mercator frames).
    pub fn latitudes(&self) -> Option<[f64; 2]> {
        let [_, y0, _, y1] = self.bounds();
        if self.degrees {
            Some([y0, y1])
        } else if self.web_mercator {
            Some([y0, y1].map(geodesy::web_mercator_latitude))
        } else {
            None
        }
    }

    /// The largest relative difference between the east-west cell size at the raster's
    /// middle row and at its north or south edge: 0 where the frame's scale is fixed.
    pub fn scale_variation(&self) -> f64 {
        if !self.varies_by_row() {
            return 0.0;
        }
        let middle = self.cell_metres()[0];
        [0.0, f64::from(self.height)]
            .iter()
            .map(|&rows| (self.cell_metres_at(rows)[0] / middle - 1.0).abs())
            .fold(0.0, f64::max)
    }

    /// Whether `other` covers the same cells: the same size in cells, cell size and
    /// origin (within a millionth of a cell) and the same kind of frame units, whatever
    /// each calls its frame (a table's "map", a GeoTIFF's CRS).
    pub fn same_grid(&self, other: &GeoRef) -> bool {
        let [sx, sy] = self.cell_size();
        let [ox, oy] = other.cell_size();
        let close = |a: f64, b: f64, unit: f64| (a - b).abs() <= 1e-6 * unit.abs();
        (self.width, self.height) == (other.width, other.height)
            && close(sx, ox, sx)
            && close(sy, oy, sy)
            && close(self.origin[0], other.origin[0], sx)
            && close(self.origin[1], other.origin[1], sy)
            && (self.degrees, self.web_mercator) == (other.degrees, other.web_mercator)
    }

    /// Whether the ground cells are square (within a relative 1e-9).
    pub fn is_square(&self) -> bool {
        let [mx, my] = self.cell_metres();
        (mx - my).abs() <= 1e-9 * mx.max(my)
    }

    pub fn cell_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    pub fn contains(&self, cell: Cell) -> bool {
        cell.row < self.height && cell.col < self.width
    }

    pub fn index(&self, cell: Cell) -> usize {
        cell.row as usize * self.width as usize + cell.col as usize
    }

    pub fn cell_at(&self, index: usize) -> Cell {
        let width = self.width as usize;
        Cell::new((index / width) as u32, (index % width) as u32)
    }

    /// The cell containing world point (x, y), or `None` off the map.
    pub fn cell_of(&self, x: f64, y: f64) -> Option<Cell> {
        let [sx, sy] = self.cell_size();
        let col = ((x - self.origin[0]) / sx).floor();
        let row = ((y - self.origin[1]) / sy).floor();
        let inside =
            col >= 0.0 && row >= 0.0 && col < f64::from(self.width) && row < f64::from(self.height);
        inside.then(|| Cell::new(row as u32, col as u32))
    }

    /// World (x, y) of a cell's centre.
    pub fn center_of(&self, cell: Cell) -> (f64, f64) {
        let [sx, sy] = self.cell_size();
        (
            self.origin[0] + (f64::from(cell.col) + 0.5) * sx,
            self.origin[1] + (f64::from(cell.row) + 0.5) * sy,
        )
    }

    /// The world rectangle the map covers: (min x, min y, max x, max y).
    pub fn bounds(&self) -> [f64; 4] {
        let [sx, sy] = self.cell_size();
        [
            self.origin[0],
            self.origin[1],
            self.origin[0] + f64::from(self.width) * sx,
            self.origin[1] + f64::from(self.height) * sy,
        ]
    }

    /// Checks the numbers describe a usable raster.
    pub fn validate(&self) -> Result<(), String> {
        if self.width == 0 || self.height == 0 {
            return Err(format!("empty raster ({}x{})", self.width, self.height));
        }
        for size in self.cell_size() {
            if !(size.is_finite() && size > 0.0) {
                return Err(format!("resolution must be > 0, got {size}"));
            }
        }
        if self.degrees && self.web_mercator {
            return Err("a frame cannot be both in degrees and Web Mercator".into());
        }
        if let Some(scale) = self.ground_scale {
            if !scale.per_axis().iter().all(|s| s.is_finite() && *s > 0.0) {
                return Err(format!("ground_scale must be > 0, got {scale:?}"));
            }
            if self.varies_by_row() {
                return Err(
                    "a ground scale is for projected frames, not degrees or Web \
                            Mercator"
                        .into(),
                );
            }
        }
        if let Some(crs) = &self.tiff_crs {
            let factor = crs.frame_units_per_unit;
            if !(factor.is_finite() && factor > 0.0) {
                return Err(format!(
                    "tiff_crs.frame_units_per_unit must be > 0, got {factor}"
                ));
            }
        }
        if !self.origin.iter().all(|v| v.is_finite()) {
            return Err(format!("origin must be finite, got {:?}", self.origin));
        }
        Ok(())
    }
}

/// A cell of a raster, by row (north) and column (east).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct Cell {
    pub row: u32,
    pub col: u32,
}

impl Cell {
    pub const fn new(row: u32, col: u32) -> Self {
        Cell { row, col }
    }

    /// Chebyshev distance: the number of 8-neighbour steps between two cells.
    pub fn chebyshev(self, other: Cell) -> u32 {
        self.row
            .abs_diff(other.row)
            .max(self.col.abs_diff(other.col))
    }

    pub fn distance_squared(self, other: Cell) -> u64 {
        let dr = u64::from(self.row.abs_diff(other.row));
        let dc = u64::from(self.col.abs_diff(other.col));
        dr * dr + dc * dc
    }
}

impl std::fmt::Display for Cell {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "(row {}, col {})", self.row, self.col)
    }
}

/// A raster of values with its georeference.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid<T> {
    pub geo: GeoRef,
    pub data: Vec<T>,
}

impl<T: Copy> Grid<T> {
    pub fn filled(geo: GeoRef, value: T) -> Self {
        let data = vec![value; geo.cell_count()];
        Grid { geo, data }
    }

    /// Wraps `data` (row by row), which must hold exactly one value per cell.
    pub fn from_vec(geo: GeoRef, data: Vec<T>) -> Self {
        assert_eq!(
            data.len(),
            geo.cell_count(),
            "grid data does not match its size"
        );
        Grid { geo, data }
    }

    pub fn width(&self) -> u32 {
        self.geo.width
    }

    pub fn height(&self) -> u32 {
        self.geo.height
    }

    pub fn get(&self, cell: Cell) -> T {
        self.data[self.geo.index(cell)]
    }

    pub fn set(&mut self, cell: Cell, value: T) {
        let i = self.geo.index(cell);
        self.data[i] = value;
    }
}

/// A dense per-cell feature stack, stored plane by plane (feature after feature, each
/// a row-major raster): operators write their own contiguous plane in parallel, and a
/// linear cost is a weighted sum of planes.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureStack {
    pub geo: GeoRef,
    pub names: Vec<String>,
    /// `names.len()` planes of `geo.cell_count()` values.
    pub data: Vec<f32>,
}

impl FeatureStack {
    pub fn dim(&self) -> usize {
        self.names.len()
    }

    /// Feature `j` over the whole map, row by row.
    pub fn plane(&self, j: usize) -> &[f32] {
        let n = self.geo.cell_count();
        &self.data[j * n..(j + 1) * n]
    }

    pub fn planes(&self) -> impl Iterator<Item = &[f32]> {
        self.data.chunks_exact(self.geo.cell_count().max(1))
    }

    /// Copies the feature vector of the cell with row-major index `index` into `out`.
    pub fn cell_into(&self, index: usize, out: &mut [f32]) {
        for (o, plane) in out.iter_mut().zip(self.planes()) {
            *o = plane[index];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_same_grid_whatever_its_frame_is_called() {
        let grid = GeoRef::square(4, 3, 0.5, [10.0, -2.0], "EPSG:32633");
        assert!(grid.same_grid(&GeoRef::square(4, 3, 0.5, [10.0, -2.0], "map")));
        // A millionth of a cell is rounding; more is another grid.
        assert!(grid.same_grid(&GeoRef::square(4, 3, 0.5, [10.0 + 1e-8, -2.0], "map")));
        for other in [
            GeoRef::square(4, 4, 0.5, [10.0, -2.0], "map"),
            GeoRef::square(4, 3, 0.25, [10.0, -2.0], "map"),
            GeoRef::square(4, 3, 0.5, [10.5, -2.0], "map"),
            GeoRef {
                degrees: true,
                ..grid.clone()
            },
        ] {
            assert!(!grid.same_grid(&other), "{other:?}");
        }
    }

    fn geo() -> GeoRef {
        GeoRef::square(4, 3, 0.5, [10.0, -2.0], "map")
    }

    #[test]
    fn world_and_cell_coordinates_agree() {
        let g = geo();
        let c = Cell::new(2, 3);
        let (x, y) = g.center_of(c);
        assert_eq!((x, y), (11.75, -0.75));
        assert_eq!(g.cell_of(x, y), Some(c));
        assert_eq!(g.cell_of(10.0, -2.0), Some(Cell::new(0, 0)));
        assert_eq!(g.cell_of(12.0, -2.0), None, "the east edge is outside");
        assert_eq!(g.cell_of(9.99, -1.0), None);
        assert_eq!(g.cell_of(f64::NAN, 0.0), None);
    }

    #[test]
    fn index_round_trips() {
        let g = geo();
        for i in 0..g.cell_count() {
            assert_eq!(g.index(g.cell_at(i)), i);
        }
    }

    #[test]
    fn validate_rejects_degenerate_rasters() {
        let mut g = geo();
        assert!(g.validate().is_ok());
        g.resolution = 0.0;
        assert!(g.validate().is_err());
        g = geo();
        g.width = 0;
        assert!(g.validate().is_err());
        g = geo();
        g.resolution_y = Some(-1.0);
        assert!(g.validate().is_err());
    }

    #[test]
    fn rectangular_cells_place_points_per_axis() {
        let mut g = geo();
        g.resolution_y = Some(2.0);
        assert_eq!(g.center_of(Cell::new(1, 1)), (10.75, 1.0));
        assert_eq!(g.cell_of(10.75, 1.0), Some(Cell::new(1, 1)));
        assert_eq!(g.bounds(), [10.0, -2.0, 12.0, 4.0]);
        assert_eq!(g.cell_metres(), [0.5, 2.0]);
        assert!(!g.is_square());
    }

    #[test]
    fn geographic_cells_are_measured_at_the_middle_latitude() {
        // 1/1200° cells around 45° N: about 65.7 m east-west and 92.6 m north-south.
        let mut g = GeoRef::square(120, 120, 1.0 / 1200.0, [7.0, 44.95], "EPSG:4326");
        g.degrees = true;
        let [mx, my] = g.cell_metres();
        assert!((mx - 65.7).abs() < 0.2, "{mx}");
        assert!((my - 92.6).abs() < 0.2, "{my}");
        assert!(g.scale_variation() < 0.002);
        // A whole hemisphere is far from one scale.
        let world = GeoRef {
            degrees: true,
            ..GeoRef::square(100, 80, 1.0, [0.0, 0.0], "EPSG:4326")
        };
        assert!(world.scale_variation() > 0.5);
    }
}
