//! `ingest`: maps and demonstrations in, a dataset out: the maps, the demonstrations,
//! and each demonstration rasterised into a connected 8-neighbour cell path. Maps come
//! from Parquet tables, GeoTIFF rasters, MovingAI `.map` files or the logs' map topic;
//! demonstrations from a Parquet or CSV table, LeRobot datasets, GPS tracks (GPX), drawn
//! paths (GeoJSON, GeoPackage, KML) or robot logs (MCAP).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{StageParams, StageReport, commit_artifact};
use crate::artifact::ArtifactBuilder;
use crate::error::{Error, Result, first_error_in_order};
use crate::grid::{
    Demonstration, Edges, GeoRef, Layer, Map, PathError, Reprojection, check_map_name, coarsened,
    factor_for_cells, factor_for_metres, rasterize, resampled_layers,
};
use crate::io::demo_tables::{Columns, read_demonstrations_table, read_lerobot};
use crate::io::geojson::{DrawnPaths, read_geojson_paths};
use crate::io::geopackage_paths::read_geopackage_paths;
use crate::io::gpx::{GPX_CRS, read_gpx};
use crate::io::kml::read_kml_paths;
use crate::io::mcap::episodes::{Split, TopicMapping, read_log};
use crate::io::mcap::frames::Planar;
use crate::io::movingai;
use crate::io::nav2::read_nav2_map;
use crate::io::tables::{EpisodePath, read_map, write_demonstrations, write_map, write_paths};
use crate::io::{RASTER_EXTENSIONS, map_name, raster_sidecars, read_raster};

pub const KIND: &str = "ingest";
/// 3: GeoTIFFs as GDAL writes them (non-square and geographic cells measured in
/// metres per axis, more compressions, band units and descriptions). 4: layers of
/// palette GeoTIFFs, and of bands GDAL's sidecar declares classes, stored as declared
/// classes. 5: staircase corners that a densely logged track only clipped are left out
/// of its cell path (`grid::rasterize`). 6: a projected CRS in feet keeps its
/// coordinates (poses are given in them), measured in metres by `ground_scale`. 7: a
/// CRS the GeoTIFF keys define by parameters alone keeps its PROJ string with the map.
const VERSION: u32 = 7;

fn default_split() -> Split {
    Split::File
}

fn default_gap() -> f64 {
    2.0
}

/// Parameters of `imitate ingest` and of `uses: ingest`.
#[derive(Debug, Clone, clap::Args, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IngestParams {
    /// Map layers: a Parquet `map/1` table, a GeoTIFF (.tif, .tiff; bands become layers
    /// band1, band2, ...), an Esri ASCII grid (.asc, its CRS from the .prj beside it;
    /// layer band1), an SRTM tile (.hgt or zipped .hgt.zip; layer elevation), a GDAL
    /// virtual raster (.vrt: gdalbuildvrt's mosaics of tiles and stacks of bands), a
    /// JPEG 2000 raster (.jp2: Sentinel-2's bands), a georeferenced PNG or JPEG (.png,
    /// .jpg: by its .aux.xml sidecar or world file), a raw raster with an ESRI header
    /// (.bil, .bip, .bsq, GridFloat .flt: EarthExplorer's SRTM and GTOPO30 tiles), a
    /// DTED tile (.dt0, .dt1, .dt2; layer elevation), a USGS ASCII DEM or GTOPO30 tile
    /// (.dem; layer elevation), gridded XYZ text (.xyz, as LiDAR
    /// DEMs come), an ERDAS Imagine file (.img: the USGS's NED and NLCD), an ENVI raster
    /// (.img, .dat, .envi, .bsq... beside its ENVI .hdr: hyperspectral and SAR scenes), a
    /// netCDF grid (.nc, .nc4, .cdf, GMT's .grd, h5netcdf's .h5: GEBCO, ETOPO, reanalyses; a layer per
    /// gridded variable and time step), a Surfer grid (.grd), an R raster (.grd beside
    /// its .gri: R's `raster` package), a GeoPackage raster
    /// (.gpkg: imagery tiles or a gridded coverage), an MBTiles package or PMTiles archive
    /// (.mbtiles, .pmtiles: Web Mercator imagery tiles), a SAGA grid (.sdat or .sgrd,
    /// compressed .sg-grd-z: SAGA's and QGIS's terrain tools), a Zarr store (a .zarr
    /// folder, version 2 or 3, as xarray writes it), an ER Mapper raster (.ers beside its
    /// samples: Geoscience Australia's grids) or a MovingAI .map (layer `blocked`);
    /// several after one --map (as a shell glob gives them) or --map repeated. Maps from files other than tables are named after their file.
    #[arg(long = "map", value_name = "FILE", num_args = 1..)]
    #[serde(default)]
    pub maps: Vec<PathBuf>,
    /// A map made of several rasters of one site, as they come (a DEM and an
    /// orthophoto): NAME=FIRST,SECOND,... The map takes the first raster's grid and CRS;
    /// every band of every raster is a layer, the others laid on that grid (bilinear
    /// from coarser cells, averaged from finer ones, through the CRSs where they
    /// differ). A raster's undescribed bands are named after its file: `dem` for a
    /// single band, `ortho_band1`, ... for several. Repeat for several maps.
    #[arg(long = "stack", value_name = "NAME=FILE,FILE")]
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stacks: Vec<String>,
    /// Demonstrations as a Parquet table, or a CSV file with a header row (as pandas,
    /// polars, spreadsheets and ROS bag exporters write them; `.csv`): columns episode,
    /// map, t, x, y[, yaw], or as --column renames them. With no episode column the file
    /// is one episode named after it; with no map column every row is on the default map.
    #[arg(long, value_name = "FILE")]
    #[serde(default)]
    pub demonstrations: Option<PathBuf>,
    /// Which column of the demonstrations table (or LeRobot dataset) plays which role:
    /// ROLE=COLUMN with roles episode, map, t, x, y, yaw; a list column's element as
    /// COLUMN[i] (e.g. x=observation.state[0]). Repeat for several.
    #[arg(long = "column", value_name = "ROLE=COLUMN")]
    #[serde(default)]
    pub columns: Vec<String>,
    /// The CRS the demonstrations table's and LeRobot datasets' poses are given in,
    /// where it is not their map's: EPSG:CODE (EPSG:4326 for GPS longitude and
    /// latitude, x the longitude) or a PROJ string. Each pose (and heading) is moved
    /// into its map's CRS, which the map must name (GeoTIFF maps do).
    #[arg(long, value_name = "CRS")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub demonstrations_crs: Option<String>,
    /// GPS tracks as GPX files: every track segment an episode on the default map, its
    /// points moved from WGS84 longitude and latitude into the map's CRS (the map must
    /// name one, as GeoTIFF maps do) and timed by their <time>. Several after one --gpx
    /// or --gpx repeated.
    #[arg(long = "gpx", value_name = "FILE", num_args = 1..)]
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gpx: Vec<PathBuf>,
    /// Paths as GeoJSON LineStrings (routes an expert drew over imagery in QGIS or
    /// geojson.io, or recorded): every LineString, and every part of a
    /// MultiLineString, an episode from its first vertex to its last, on the map its
    /// `map` property names or the default map, named by its `episode` or `name`
    /// property. Coordinates in WGS 84 longitude and latitude (RFC 7946) or the CRS a
    /// `crs` member names, moved into the map's CRS. Several after one --geojson.
    #[arg(long = "geojson", value_name = "FILE", num_args = 1..)]
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub geojson: Vec<PathBuf>,
    /// Paths as a GeoPackage of lines (.gpkg: how QGIS saves a new line layer by
    /// default): every line layer read as --geojson reads a file, its features' `map`,
    /// `episode` and `name` columns as those properties, coordinates in the layer's
    /// CRS (an EPSG code) moved into the map's. Several after one --gpkg.
    #[arg(long = "gpkg", value_name = "FILE", num_args = 1..)]
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gpkg: Vec<PathBuf>,
    /// Paths as KML or KMZ (routes drawn in Google Earth or My Maps, tracks recorded as
    /// gx:Track): every LineString of a Placemark an episode timed by its vertices'
    /// order, every gx:Track one timed by its <when>s, named by the placemark's <name>,
    /// on the map its ExtendedData field `map` names or the default map; WGS 84
    /// longitude and latitude moved into the map's CRS. Several after one --kml.
    #[arg(long = "kml", value_name = "FILE", num_args = 1..)]
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub kml: Vec<PathBuf>,
    /// LeRobot v2/v3 dataset folders (meta/info.json, data/chunk-*/...parquet); the pose
    /// is read from observation.state elements named x, y (yaw) unless --column says.
    #[arg(long = "lerobot", value_name = "DIR", num_args = 1..)]
    #[serde(default)]
    pub lerobot: Vec<PathBuf>,
    /// Robot logs (MCAP) to take demonstrations (and maps) from; several after one --log
    /// or --log repeated.
    #[arg(long = "log", value_name = "FILE", num_args = 1..)]
    #[serde(default)]
    pub logs: Vec<PathBuf>,
    /// The logs' map topic (OccupancyGrid, GridMap or foxglove.Grid); default: the only
    /// channel of such a type, if there is one. The map is named after the log file.
    #[arg(long, value_name = "TOPIC")]
    #[serde(default)]
    pub map_topic: Option<String>,
    /// The logs' pose topic (Odometry, PoseStamped, PoseWithCovarianceStamped, Path,
    /// foxglove.PoseInFrame/PosesInFrame); default: the only channel of such a type.
    #[arg(long, value_name = "TOPIC")]
    #[serde(default)]
    pub pose_topic: Option<String>,
    /// A topic whose messages each start a new episode (with --split goal).
    #[arg(long, value_name = "TOPIC")]
    #[serde(default)]
    pub goal_topic: Option<String>,
    /// How a log's poses are cut into episodes.
    #[arg(long, value_enum, default_value = "file")]
    #[serde(default = "default_split")]
    pub split: Split,
    /// With --split gap: a silence longer than this many seconds ends an episode.
    #[arg(long, default_value_t = 2.0)]
    #[serde(default = "default_gap")]
    pub gap_seconds: f64,
    /// x,y,yaw of the transform taking pose-frame coordinates into the map frame, for
    /// logs whose /tf does not link the two frames.
    #[arg(long, value_name = "X,Y,YAW", value_delimiter = ',', num_args = 3)]
    #[serde(default)]
    pub transform: Option<Vec<f64>>,
    /// Ingest what precedes damage in a log (cut short, corrupt chunk) instead of failing;
    /// a warning says where the damage is and how much was dropped.
    #[arg(long)]
    #[serde(default)]
    pub allow_truncated: bool,
    /// The map (by name) that episodes without one lie on (logs without a map topic,
    /// tables without a map column, LeRobot datasets); default: the only map given.
    #[arg(long, value_name = "NAME")]
    #[serde(default)]
    pub default_map: Option<String>,
    /// Coarsen every map so that its longer side has at most this many cells: blocks
    /// of whole cells averaged (GDAL's `average`; class layers take each block's most
    /// common class, as its `mode` does), the last block along an axis clipped to the
    /// raster. For rasters finer than the plans need: time and memory grow with cells.
    #[arg(long, value_name = "N", conflicts_with = "cell_size")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cells: Option<u32>,
    /// Coarsen every map to cells of about this many metres on the ground: blocks of
    /// the whole number of cells nearest it, averaged as with --cells.
    #[arg(long, value_name = "METRES")]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cell_size: Option<f64>,
    /// The dataset folder to write.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
}

/// A map file of any supported kind, chosen by its extension.
fn load_map(path: &Path) -> Result<Map> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match extension.as_str() {
        "parquet" => read_map(path),
        raster if RASTER_EXTENSIONS.contains(&raster) => read_raster(path, &map_name(path)),
        "map" => movingai::read_map_layer(path, &map_name(path)),
        "yaml" | "yml" => read_nav2_map(path, &map_name(path)),
        other => Err(Error::input(
            path,
            format!(
                "maps are .parquet, .tif/.tiff (GeoTIFF), .asc (Esri ASCII grid), .hgt \
                 (SRTM tile), .hgt.zip, .vrt (GDAL virtual raster), .jp2 (JPEG 2000), .png/.jpg \
                 (georeferenced image), .bil/.bip/.bsq/.flt (raw raster with an ESRI .hdr), \
                 .dt0/.dt1/.dt2 (DTED), .dem (USGS DEM, GTOPO30), .xyz (gridded XYZ), .img (ERDAS Imagine or ENVI), \
                 .dat/.envi (ENVI), .nc/.nc4/.cdf/.h5/.grd (netCDF, Surfer, R raster), .gpkg (GeoPackage raster), \
                 .mbtiles (MBTiles), .pmtiles (PMTiles), .sdat/.sgrd/.sg-grd-z (SAGA grid), \
                 .zarr (Zarr store), .ers (ER Mapper), .map (MovingAI) or .yaml (Nav2) files, \
                 not '.{other}'"
            ),
        )),
    }
}

/// A `--stack` entry: the map's name and its files, in order.
fn parse_stack(entry: &str) -> Result<(String, Vec<PathBuf>)> {
    let usage = || {
        Error::Usage(format!(
            "stack '{entry}' is not NAME=FILE,FILE,...: a map name, then its rasters"
        ))
    };
    let (name, files) = entry.split_once('=').ok_or_else(usage)?;
    let files: Vec<PathBuf> = files
        .split(',')
        .map(str::trim)
        .filter(|f| !f.is_empty())
        .map(PathBuf::from)
        .collect();
    if name.trim().is_empty() || files.is_empty() {
        return Err(usage());
    }
    Ok((name.trim().to_string(), files))
}

/// The layers of one file of a stack, named as the stack names them: bands the file
/// describes keep their descriptions; a single undescribed band takes the file's stem,
/// several take `<stem>_bandN`.
fn stack_layer_names(path: &Path, map: &mut Map) {
    let stem = map_name(path);
    let single = map.layers.len() == 1;
    for (i, layer) in map.layers.iter_mut().enumerate() {
        if layer.name == format!("band{}", i + 1) {
            layer.name = if single {
                stem.clone()
            } else {
                format!("{stem}_band{}", i + 1)
            };
        }
    }
}

/// The map of a `--stack` entry: the first file's grid with every file's layers.
fn load_stack(entry: &str) -> Result<Map> {
    let (name, files) = parse_stack(entry)?;
    let parts = first_error_in_order(files.par_iter().map(|p| load_map(p)).collect())?;
    let geo = parts[0].geo.clone();
    let mut layers: Vec<Layer> = Vec::new();
    for (mut part, path) in parts.into_iter().zip(&files) {
        stack_layer_names(path, &mut part);
        let laid = resampled_layers(&part.layers, &part.geo, &geo).map_err(|why| {
            Error::input(
                path,
                format!(
                    "cannot be laid on the grid of {}: {why}; warp it to that raster's CRS \
                     first (gdalwarp -t_srs)",
                    files[0].display()
                ),
            )
        })?;
        for layer in laid {
            if layers.iter().any(|l| l.name == layer.name) {
                return Err(Error::input(
                    path,
                    format!(
                        "a second layer named '{}' in the stack '{name}' (name the bands, \
                         or the files, apart)",
                        layer.name
                    ),
                ));
            }
            if layer.values.iter().all(|v| v.is_nan()) {
                return Err(Error::input(
                    path,
                    format!(
                        "layer '{}' has no data on the grid of {}: the rasters do not overlap",
                        layer.name,
                        files[0].display()
                    ),
                ));
            }
            layers.push(layer);
        }
    }
    Ok(Map { name, geo, layers })
}

/// Moves every pose of `demos` from `crs` into its map's frame. Episodes on maps not
/// given are left for the check that names them.
fn reproject_into_maps(
    demos: &mut [(Demonstration, PathBuf)],
    crs: &str,
    maps: &[Map],
    what: &str,
) -> Result<()> {
    let mut reprojections = std::collections::BTreeMap::new();
    for (demo, source) in demos.iter_mut() {
        let source = &*source;
        let Some(map) = maps.iter().find(|m| m.name == demo.map) else {
            continue;
        };
        if !reprojections.contains_key(&map.name) {
            let reprojection = Reprojection::new(crs, &map.geo).map_err(|why| {
                Error::Usage(format!(
                    "{what}: poses cannot be moved into map '{}': {why}; give them in the \
                     map's own coordinates",
                    map.name
                ))
            })?;
            reprojections.insert(map.name.clone(), reprojection);
        }
        let reprojection = &reprojections[&map.name];
        for (index, pose) in demo.poses.iter_mut().enumerate() {
            let moved = reprojection.point(pose.x, pose.y).and_then(|(x, y)| {
                let yaw = match pose.yaw {
                    Some(yaw) => Some(reprojection.heading(pose.x, pose.y, yaw)?),
                    None => None,
                };
                Ok((x, y, yaw))
            });
            let (x, y, yaw) = moved.map_err(|why| {
                Error::input(
                    source,
                    format!(
                        "episode '{}': pose {index} at (x {}, y {}) of {crs} cannot be \
                         moved into map '{}' ({}): {why}",
                        demo.episode, pose.x, pose.y, map.name, map.geo.frame
                    ),
                )
            })?;
            (pose.x, pose.y, pose.yaw) = (x, y, yaw);
        }
    }
    Ok(())
}

/// Consumer GPS fixes are good to a few metres (GPS.gov: 4.9 m, 95 %, for a phone in
/// the open): their tracks wander over cells finer than that.
const GPS_METRES: f64 = 3.0;

/// Warns when GPS tracks lie on cells so fine that their error spans several.
fn warn_of_cells_finer_than_gps(map: &Map) {
    let [x, y] = map.geo.cell_metres();
    let cell = x.min(y);
    if cell < GPS_METRES / 1.5 {
        tracing::warn!(
            "map '{}' has cells of {cell:.2} m: GPS fixes, good to a few metres, wander over \
             several of them; coarsen it toward their accuracy (--cell-size {GPS_METRES}) \
             or leave learch's --corridor auto to take the wander",
            map.name
        );
    }
}

/// Why poses may lie off a map although the user meant them on it: they look like
/// longitude and latitude, and the map's CRS is projected.
fn off_map_hint(geo: &GeoRef, demo: &Demonstration, crs_given: bool) -> String {
    let degrees_like = demo
        .poses
        .iter()
        .all(|p| p.x.abs() <= 180.0 && p.y.abs() <= 90.0);
    if crs_given || geo.degrees || !geo.frame.starts_with("EPSG:") || !degrees_like {
        return String::new();
    }
    format!(
        "; the poses look like longitude and latitude: name their CRS \
         (--demonstrations-crs EPSG:4326, or demonstrations_crs in a pipeline) to move \
         them into the map's {}",
        geo.frame
    )
}

/// Refuses a map file given twice, or two GeoTIFF/MovingAI files that would get one
/// name (they are named after their files), before any map is loaded: a long list of
/// one map would otherwise fill memory before the second copy is refused.
fn refuse_repeated_maps(paths: &[PathBuf]) -> Result<()> {
    let mut seen = BTreeSet::new();
    let mut stems = BTreeSet::new();
    for path in paths {
        if !seen.insert(path) {
            return Err(Error::input(path, "is given twice as a map"));
        }
        let named_after_file = !path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("parquet"));
        if named_after_file && !stems.insert(map_name(path)) {
            return Err(Error::input(
                path,
                format!(
                    "a second map named '{}' (maps from GeoTIFF and .map files are named after their file)",
                    map_name(path)
                ),
            ));
        }
    }
    Ok(())
}

impl IngestParams {
    fn mapping(&self) -> Result<TopicMapping> {
        let transform = match self.transform.as_deref() {
            None => None,
            Some(&[x, y, yaw]) if [x, y, yaw].iter().all(|v| v.is_finite()) => {
                Some(Planar { x, y, yaw })
            }
            Some(other) => {
                return Err(Error::Usage(format!(
                    "transform must be three finite numbers x,y,yaw, not {other:?}"
                )));
            }
        };
        if !(self.gap_seconds.is_finite() && self.gap_seconds > 0.0) {
            return Err(Error::Usage("gap_seconds must be a positive number".into()));
        }
        Ok(TopicMapping {
            map_topic: self.map_topic.clone(),
            pose_topic: self.pose_topic.clone(),
            goal_topic: self.goal_topic.clone(),
            split: self.split,
            gap_seconds: self.gap_seconds,
            transform,
            allow_truncated: self.allow_truncated,
        })
    }

    /// The maps of the map files and of the stacks, and the file each is named after
    /// (a stack's first) for messages.
    fn load_maps(&self) -> Result<(Vec<Map>, Vec<PathBuf>)> {
        refuse_repeated_maps(&self.maps)?;
        let mut maps = first_error_in_order(self.maps.par_iter().map(|p| load_map(p)).collect())?;
        let mut sources = self.maps.clone();
        for entry in &self.stacks {
            maps.push(load_stack(entry)?);
            sources.push(parse_stack(entry)?.1.swap_remove(0));
        }
        Ok((maps, sources))
    }

    /// Each map coarsened as `cells` or `cell_size` asks (unchanged when neither does).
    fn coarsen(&self, maps: Vec<Map>) -> Result<Vec<Map>> {
        if let Some(metres) = self.cell_size
            && !(metres.is_finite() && metres > 0.0)
        {
            return Err(Error::Usage(format!(
                "cell_size must be a positive number of metres, not {metres}"
            )));
        }
        Ok(maps
            .into_iter()
            .map(|map| {
                let factor = match (self.cells, self.cell_size) {
                    (Some(cells), _) => factor_for_cells(&map.geo, cells),
                    (None, Some(metres)) => factor_for_metres(&map.geo, metres),
                    (None, None) => 1,
                };
                coarsened(map, factor, Edges::Kept)
            })
            .collect())
    }

    /// The map of episodes that name none: `default_map`, or the only map given.
    fn default_map<'a>(&self, maps: &'a [Map]) -> Result<Option<&'a Map>> {
        match &self.default_map {
            Some(name) => Ok(Some(maps.iter().find(|m| &m.name == name).ok_or_else(
                || Error::Usage(format!("default_map '{name}' is not among the maps given")),
            )?)),
            None if maps.len() == 1 => Ok(Some(&maps[0])),
            None => Ok(None),
        }
    }

    /// The demonstrations of the table and the LeRobot datasets.
    fn read_tables(&self, maps: &[Map]) -> Result<Vec<(Demonstration, PathBuf)>> {
        let default_map = self.default_map(maps)?.map(|m| m.name.as_str());
        let mut demos = Vec::new();
        if let Some(path) = &self.demonstrations {
            let columns = Columns::default()
                .with_overrides(&self.columns)
                .map_err(Error::Usage)?;
            let table = read_demonstrations_table(path, &columns, default_map)?;
            demos.extend(table.into_iter().map(|d| (d, path.clone())));
        }
        for folder in &self.lerobot {
            let dataset = read_lerobot(folder, &self.columns, default_map)?;
            demos.extend(dataset.into_iter().map(|d| (d, folder.clone())));
        }
        if let Some(crs) = &self.demonstrations_crs {
            reproject_into_maps(&mut demos, crs, maps, "demonstrations_crs")?;
        }
        if !self.gpx.is_empty() {
            let map = default_map.ok_or_else(|| {
                Error::Usage(
                    "GPX tracks name no map: give the map they lie on (--default-map NAME, \
                     or default_map in a pipeline)"
                        .into(),
                )
            })?;
            let mut tracks = Vec::new();
            for path in &self.gpx {
                let read = read_gpx(path, map)?;
                tracks.extend(read.into_iter().map(|d| (d, path.clone())));
            }
            reproject_into_maps(&mut tracks, GPX_CRS, maps, "GPX tracks (WGS84)")?;
            demos.extend(tracks);
        }
        let geojson = self.geojson.iter().map(|path| {
            Ok((
                path,
                "GeoJSON",
                vec![read_geojson_paths(path, default_map)?],
            ))
        });
        let gpkg = self.gpkg.iter().map(|path| {
            Ok((
                path,
                "GeoPackage",
                read_geopackage_paths(path, default_map)?,
            ))
        });
        let kml = self
            .kml
            .iter()
            .map(|path| Ok((path, "KML", vec![read_kml_paths(path, default_map)?])));
        for read in geojson.chain(gpkg).chain(kml) {
            let (path, format, layers): (&PathBuf, &str, Vec<DrawnPaths>) = read?;
            for drawn in layers {
                let mut paths: Vec<_> = drawn
                    .demonstrations
                    .into_iter()
                    .map(|d| (d, path.clone()))
                    .collect();
                let what = format!("{format} paths ({})", drawn.crs);
                reproject_into_maps(&mut paths, &drawn.crs, maps, &what)?;
                demos.extend(paths);
            }
        }
        Ok(demos)
    }

    /// Log `index`'s map and demonstrations, as `run` reads them: what a worker that
    /// ingests one log of many returns (see `run_with`).
    pub fn read_log_part(&self, index: usize) -> Result<LogPart> {
        let log = self
            .logs
            .get(index)
            .ok_or_else(|| Error::Usage(format!("log {index} of {} logs", self.logs.len())))?;
        let (maps, _) = self.load_maps()?;
        let fallback = self
            .default_map(&maps)?
            .map(|m| (m.name.as_str(), m.geo.frame.as_str()));
        let contents = read_log(log, &self.mapping()?, fallback)?;
        Ok((contents.map, contents.demonstrations))
    }

    /// The demonstrations and maps of every log, in the order the logs are given.
    fn read_logs(&self, maps: &[Map]) -> Result<Vec<LogPart>> {
        if self.logs.is_empty() {
            return Ok(Vec::new());
        }
        let mapping = self.mapping()?;
        let fallback = self
            .default_map(maps)?
            .map(|m| (m.name.as_str(), m.geo.frame.as_str()));
        let progress = super::progress_bar(self.logs.len(), "logs");
        let results: Vec<Result<_>> = self
            .logs
            .par_iter()
            .map(|log| {
                let read = read_log(log, &mapping, fallback).map(|c| (c.map, c.demonstrations));
                progress.inc(1);
                read
            })
            .collect();
        progress.finish_and_clear();
        first_error_in_order(results)
    }
}

impl StageParams for IngestParams {
    const KIND: &'static str = KIND;
    const VERSION: u32 = VERSION;

    fn deps(&self) -> Vec<PathBuf> {
        let stacked = self
            .stacks
            .iter()
            .filter_map(|entry| parse_stack(entry).ok())
            .flat_map(|(_, files)| files);
        let mut deps: Vec<PathBuf> = self.maps.iter().cloned().chain(stacked).collect();
        // A GeoTIFF's sidecars can georeference it or declare its bands classes:
        // adding, changing or removing one makes the maps stale.
        let sidecars: Vec<PathBuf> = deps.iter().flat_map(|map| raster_sidecars(map)).collect();
        deps.extend(sidecars);
        deps.extend(self.demonstrations.clone());
        deps.extend(self.logs.iter().cloned());
        deps.extend(self.lerobot.iter().cloned());
        deps.extend(self.gpx.iter().cloned());
        deps.extend(self.geojson.iter().cloned());
        deps.extend(self.gpkg.iter().cloned());
        deps.extend(self.kml.iter().cloned());
        deps
    }

    fn out(&self) -> PathBuf {
        self.out.clone()
    }

    fn run(&self, extra_deps: &[PathBuf]) -> Result<StageReport> {
        self.run_with(extra_deps, None)
    }
}

/// What one log gives: the map it records, if any, and its demonstrations.
pub type LogPart = (Option<Map>, Vec<Demonstration>);

/// Logs decoded elsewhere: given the logs, each one's part, in the order given (e.g.
/// from workers that ran `read_log_part` on one log each).
pub type RemoteLogs<'a> = dyn FnMut(&[PathBuf]) -> Result<Vec<LogPart>> + 'a;

impl IngestParams {
    /// Runs the stage, with the logs decoded by `remote` when given: the same artifact.
    pub fn run_with(
        &self,
        extra_deps: &[PathBuf],
        remote: Option<&mut RemoteLogs<'_>>,
    ) -> Result<StageReport> {
        if self.demonstrations.is_none()
            && self.logs.is_empty()
            && self.lerobot.is_empty()
            && self.gpx.is_empty()
            && self.geojson.is_empty()
            && self.gpkg.is_empty()
            && self.kml.is_empty()
        {
            return Err(Error::Usage(
                "ingest needs demonstrations: a Parquet or CSV table, LeRobot datasets, GPS \
                 tracks (GPX), paths (GeoJSON, GeoPackage, KML) or logs (MCAP)"
                    .into(),
            ));
        }
        let (mut maps, mut sources) = self.load_maps()?;
        let mut demos = self.read_tables(&maps)?;
        let parts = match remote {
            Some(remote) if !self.logs.is_empty() => {
                let parts = remote(&self.logs)?;
                if parts.len() != self.logs.len() {
                    return Err(Error::Failed(format!(
                        "{} logs' parts came back for {} logs",
                        parts.len(),
                        self.logs.len()
                    )));
                }
                parts
            }
            _ => self.read_logs(&maps)?,
        };
        for ((map, log_demos), log) in parts.into_iter().zip(&self.logs) {
            maps.extend(map);
            sources.resize(maps.len(), log.clone());
            demos.extend(log_demos.into_iter().map(|d| (d, log.clone())));
        }
        let maps = self.coarsen(maps)?;
        for map in &maps {
            let gps = demos
                .iter()
                .any(|(d, source)| d.map == map.name && self.gpx.contains(source));
            if gps {
                warn_of_cells_finer_than_gps(map);
            }
        }
        let mut names = BTreeSet::new();
        for (map, path) in maps.iter().zip(&sources) {
            check_map_name(&map.name).map_err(|why| Error::input(path, why))?;
            if !names.insert(map.name.clone()) {
                return Err(Error::input(
                    path,
                    format!("a second map named '{}'", map.name),
                ));
            }
        }
        let mut episodes = BTreeSet::new();
        for (demo, source) in &demos {
            if !episodes.insert(demo.episode.as_str()) {
                return Err(Error::input(
                    source,
                    format!("a second episode named '{}'", demo.episode),
                ));
            }
        }
        let mut paths = Vec::with_capacity(demos.len());
        for (demo, source) in &demos {
            let problem = |message: String| {
                Error::input(source, format!("episode '{}': {message}", demo.episode))
            };
            let map = maps.iter().find(|m| m.name == demo.map).ok_or_else(|| {
                problem(format!(
                    "refers to map '{}', which is not among the maps given ({})",
                    demo.map,
                    names.iter().cloned().collect::<Vec<_>>().join(", ")
                ))
            })?;
            let cells = rasterize(&map.geo, &demo.xy()).map_err(|e| match e {
                PathError::OffMap { .. } => {
                    let [x0, y0, x1, y1] = map.geo.bounds();
                    let moved = self.demonstrations_crs.is_some()
                        || self.gpx.contains(source)
                        || self.geojson.contains(source);
                    let hint = off_map_hint(&map.geo, demo, moved);
                    problem(format!(
                        "{e} '{}' (x {x0}..{x1}, y {y0}..{y1}){hint}",
                        map.name
                    ))
                }
                PathError::TooFewPoses(_) => problem(e.to_string()),
            })?;
            if cells.len() < 2 {
                return Err(problem(format!(
                    "starts and ends in the same cell {}",
                    cells[0]
                )));
            }
            paths.push(EpisodePath {
                episode: demo.episode.clone(),
                map: demo.map.clone(),
                cells,
            });
        }

        let mut out = ArtifactBuilder::new(&self.out)?;
        for map in &maps {
            write_map(
                &out.file(&format!("maps/{}.parquet", map.name), "map")?,
                map,
            )?;
        }
        let demos: Vec<Demonstration> = demos.into_iter().map(|(d, _)| d).collect();
        write_demonstrations(
            &out.file("demonstrations.parquet", "demonstrations")?,
            &demos,
        )?;
        write_paths(&out.file("paths.parquet", "paths")?, &paths)?;
        let metrics = serde_json::json!({
            "maps": maps.len(),
            "demonstrations": demos.len(),
            "path_cells": paths.iter().map(|p| p.cells.len()).sum::<usize>(),
        });
        let summary = format!("{} maps, {} demonstrations", maps.len(), demos.len());
        commit_artifact(self, extra_deps, out, "dataset", metrics, summary)
    }
}
