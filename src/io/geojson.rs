//! Paths as GeoJSON (RFC 7946), the vector format QGIS, geojson.io, Leaflet and every
//! GIS library open.
//!
//! Written: a FeatureCollection of LineStrings through cell centres, in WGS 84
//! longitude and latitude as the RFC requires, moved there from the map's CRS (maps with
//! no CRS have no place on the Earth and are refused).
//!
//! Read: the routes an expert drew over imagery in QGIS or geojson.io, or recorded, as
//! demonstrations: every LineString, and every part of a MultiLineString, an episode
//! from its first vertex to its last; a file of Points alone, a track recorded fix by
//! fix. Coordinates are WGS 84 longitude and latitude, or the CRS a legacy `crs` member
//! names (QGIS writes one for layers in other CRSs).

use std::path::Path;

use serde_json::{Value, json};

use super::fs::write_bytes_atomic;
use crate::error::{Error, Result, read_input};
use crate::grid::{Cell, Demonstration, GeoRef, Pose, Reprojection};

/// The CRS of GeoJSON without a `crs` member (RFC 7946).
pub const GEOJSON_CRS: &str = "EPSG:4326";

/// The demonstrations of a GeoJSON file, and the CRS their coordinates are in.
pub struct DrawnPaths {
    pub demonstrations: Vec<Demonstration>,
    /// `EPSG:<code>`: WGS 84, or what the file's `crs` member names.
    pub crs: String,
}

/// The paths of the GeoJSON file at `path`, on the map its features' `map` property
/// names or else `default_map`. Episodes are named by a feature's `episode` or `name`
/// property, else `<stem>-NNN` (its index), with `-K` for the parts of a
/// MultiLineString; they are timed by their vertices' order. A file of Points alone is
/// a recorded track ([`point_tracks`]).
pub fn read_geojson_paths(path: &Path, default_map: Option<&str>) -> Result<DrawnPaths> {
    let problem = |message: String| Error::input(path, message);
    let document: Value = serde_json::from_slice(&read_input(path)?)
        .map_err(|e| problem(format!("is not JSON: {e}")))?;
    let crs = legacy_crs(&document).map_err(problem)?;
    let features: Vec<&Value> = match document["type"].as_str() {
        Some("FeatureCollection") => document["features"]
            .as_array()
            .ok_or_else(|| problem("is a FeatureCollection without a features list".into()))?
            .iter()
            .collect(),
        Some("Feature") => vec![&document],
        Some("LineString" | "MultiLineString") => vec![&document],
        _ => {
            return Err(problem(
                "is not GeoJSON: its type is none of FeatureCollection, Feature, LineString, \
                 MultiLineString"
                    .into(),
            ));
        }
    };
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut demonstrations = Vec::new();
    let mut passed_over = 0;
    let mut points = Vec::new();
    for (index, feature) in features.iter().enumerate() {
        let (geometry, properties) = if feature["type"] == "Feature" {
            (&feature["geometry"], &feature["properties"])
        } else {
            (*feature, &Value::Null)
        };
        let parts: Vec<&Value> = match geometry["type"].as_str() {
            Some("LineString") => vec![&geometry["coordinates"]],
            Some("MultiLineString") => geometry["coordinates"]
                .as_array()
                .map(|parts| parts.iter().collect())
                .unwrap_or_default(),
            Some("Point") => {
                points.push((index, &geometry["coordinates"], properties));
                passed_over += 1;
                continue;
            }
            _ => {
                passed_over += 1;
                continue;
            }
        };
        let label = |key: &str| label(properties, key);
        let name = label("episode")
            .or_else(|| label("name"))
            .unwrap_or_else(|| format!("{stem}-{index:03}"));
        let lines = parts
            .iter()
            .enumerate()
            .map(|(k, part)| {
                positions(part)
                    .map_err(|why| format!("feature {index} ('{name}'), line {k}: {why}"))
            })
            .collect::<std::result::Result<Vec<_>, String>>()
            .map_err(&problem)?;
        let feature = DrawnFeature {
            index,
            name,
            map: label("map"),
        };
        demonstrations.extend(feature.episodes(&lines, default_map).map_err(&problem)?);
    }
    // A file of points alone is a recorded track (a GPS logger's export, GDAL's GPX
    // `track_points` layer): its points in file order.
    if demonstrations.is_empty() && !points.is_empty() {
        demonstrations = point_tracks(&stem, &points, default_map).map_err(&problem)?;
        passed_over -= points.len();
    }
    DrawnPaths::of_file(
        path,
        demonstrations,
        passed_over,
        crs,
        "LineString, MultiLineString or track of Points",
    )
}

/// A feature's property `key` as text (a string, or a number's decimal text).
fn label(properties: &Value, key: &str) -> Option<String> {
    match &properties[key] {
        Value::String(s) if !s.trim().is_empty() => Some(s.trim().to_string()),
        Value::Number(n) => Some(n.to_string()),
        _ => None,
    }
}

/// Point features (index, coordinates, properties) as tracks: grouped by their
/// `episode` property, else GDAL's `track_fid` and `track_seg_id` (`<stem>-track-NNN`,
/// `-MMM` for a segment after the first), else one track named after the file; each in
/// file order, timed by every point's `time` (or `timestamp`) as a GPX segment by its
/// times, else by their order; on the map the first point's `map` names or `default_map`.
fn point_tracks(
    stem: &str,
    points: &[(usize, &Value, &Value)],
    default_map: Option<&str>,
) -> std::result::Result<Vec<Demonstration>, String> {
    let mut tracks: Vec<(String, Option<String>, Vec<super::gpx::Fix>)> = Vec::new();
    for &(index, coordinates, properties) in points {
        let name = label(properties, "episode").unwrap_or_else(|| {
            match (
                label(properties, "track_fid"),
                label(properties, "track_seg_id"),
            ) {
                (Some(track), Some(segment)) if segment != "0" => {
                    format!("{stem}-track-{track:0>3}-{segment:0>3}")
                }
                (Some(track), _) => format!("{stem}-track-{track:0>3}"),
                (None, _) => stem.to_string(),
            }
        });
        let [lon, lat] = positions(&Value::Array(vec![coordinates.clone()]))
            .map_err(|why| format!("feature {index}: {why}"))?[0];
        let time = label(properties, "time")
            .or_else(|| label(properties, "timestamp"))
            .map(|text| {
                super::gpx::parse_time(&text)
                    .map_err(|why| format!("feature {index}: its time '{text}' {why}"))
            })
            .transpose()?;
        let fix = super::gpx::Fix { lon, lat, time };
        match tracks.iter_mut().find(|(n, ..)| *n == name) {
            Some((.., fixes)) => fixes.push(fix),
            None => tracks.push((name, label(properties, "map"), vec![fix])),
        }
    }
    tracks
        .into_iter()
        .map(|(episode, map, fixes)| {
            let map = map
                .or_else(|| default_map.map(String::from))
                .ok_or_else(|| {
                    format!(
                        "track '{episode}' names no map (a 'map' property) and no default map \
                         is given (--default-map)"
                    )
                })?;
            if fixes.len() < 2 {
                return Err(format!(
                    "track '{episode}' has {} point(s); a path needs 2",
                    fixes.len()
                ));
            }
            let poses = super::gpx::timed_poses(&fixes)
                .map_err(|why| format!("track '{episode}': {why}"))?;
            Ok(Demonstration {
                episode,
                map,
                poses,
            })
        })
        .collect()
}

impl DrawnPaths {
    /// The paths read from the file at `path`, `passed_over` features that were not
    /// lines said in a warning; an error where it held no `lines` (what a path is in its
    /// format).
    pub(super) fn of_file(
        path: &Path,
        demonstrations: Vec<Demonstration>,
        passed_over: usize,
        crs: String,
        lines: &str,
    ) -> Result<DrawnPaths> {
        warn_of_passed_over(path, passed_over);
        if demonstrations.is_empty() {
            return Err(Error::input(
                path,
                format!("holds no {lines}: paths are lines"),
            ));
        }
        Ok(DrawnPaths {
            demonstrations,
            crs,
        })
    }
}

/// A line's positions [x, y] (any further coordinate dropped).
fn positions(coordinates: &Value) -> std::result::Result<Vec<[f64; 2]>, String> {
    let vertices = coordinates
        .as_array()
        .ok_or("its coordinates are not a list of positions")?;
    vertices
        .iter()
        .enumerate()
        .map(|(i, vertex)| {
            let number = |axis: usize| vertex.get(axis).and_then(Value::as_f64);
            match (number(0), number(1)) {
                (Some(x), Some(y)) => Ok([x, y]),
                _ => Err(format!("vertex {i} ({vertex}) is not a position [x, y]")),
            }
        })
        .collect()
}

/// A drawn feature (a GeoJSON feature, a GeoPackage row): its index in its file or
/// layer, its name (its `episode` or `name`, else one made of the file or layer and
/// the index) and the map it names, if any.
pub(super) struct DrawnFeature {
    pub index: usize,
    pub name: String,
    pub map: Option<String>,
}

impl DrawnFeature {
    /// Its lines as episodes on its map or `default_map`: one line as `name`, the parts
    /// of a multi-line as `name-K`.
    pub(super) fn episodes(
        &self,
        lines: &[Vec<[f64; 2]>],
        default_map: Option<&str>,
    ) -> std::result::Result<Vec<Demonstration>, String> {
        let DrawnFeature { index, name, map } = self;
        let map = map
            .clone()
            .or_else(|| default_map.map(String::from))
            .ok_or_else(|| {
                format!(
                    "feature {index} names no map (a 'map' property or column) and no default \
                 map is given (--default-map)"
                )
            })?;
        lines
            .iter()
            .enumerate()
            .map(|(k, line)| {
                let poses = vertex_poses(line)
                    .map_err(|why| format!("feature {index} ('{name}'), line {k}: {why}"))?;
                let episode = if lines.len() == 1 {
                    name.clone()
                } else {
                    format!("{name}-{k}")
                };
                Ok(Demonstration {
                    episode,
                    map: map.clone(),
                    poses,
                })
            })
            .collect()
    }
}

/// Says how many features of the file at `path` were not lines.
pub(super) fn warn_of_passed_over(path: &Path, passed_over: usize) {
    if passed_over > 0 {
        tracing::warn!(
            "{}: {passed_over} feature(s) that are not lines passed over",
            path.display()
        );
    }
}

/// A drawn line's vertices (x, y) as poses, timed by their order: a path of two or more
/// finite vertices.
fn vertex_poses(vertices: &[[f64; 2]]) -> std::result::Result<Vec<Pose>, String> {
    if vertices.len() < 2 {
        return Err(format!("{} vertex(es); a path needs 2", vertices.len()));
    }
    vertices
        .iter()
        .enumerate()
        .map(|(i, &[x, y])| {
            if x.is_finite() && y.is_finite() {
                Ok(Pose {
                    t: i as f64,
                    x,
                    y,
                    yaw: None,
                })
            } else {
                Err(format!("vertex {i} ({x}, {y}) is not a finite position"))
            }
        })
        .collect()
}

/// The CRS of the coordinates: WGS 84, or the EPSG code of a legacy `crs` member
/// (`urn:ogc:def:crs:EPSG::32632`, `EPSG:32632`; OGC's CRS84 is WGS 84).
fn legacy_crs(document: &Value) -> std::result::Result<String, String> {
    let Some(name) = document["crs"]["properties"]["name"].as_str() else {
        return Ok(GEOJSON_CRS.to_string());
    };
    let upper = name.to_ascii_uppercase();
    if upper.ends_with("CRS84") || upper.ends_with("CRS:84") {
        return Ok(GEOJSON_CRS.to_string());
    }
    let code = upper
        .rsplit_once("EPSG:")
        .map(|(_, code)| code.trim_start_matches(':'))
        .and_then(|code| code.rsplit(':').next())
        .filter(|code| !code.is_empty() && code.bytes().all(|b| b.is_ascii_digit()));
    match code {
        Some(code) => Ok(format!("EPSG:{code}")),
        None => Err(format!(
            "its crs member names '{name}', not an EPSG code (urn:ogc:def:crs:EPSG::<code>)"
        )),
    }
}

/// One path: its cells, and what the feature's properties say of it.
pub struct Line<'a> {
    pub properties: Value,
    pub cells: &'a [Cell],
}

/// The RFC 7946 FeatureCollection of `lines` on `geo`, or why the map cannot give one
/// (`source` names what the map came from).
pub fn line_collection(geo: &GeoRef, lines: &[Line], source: &Path) -> Result<String> {
    let to_wgs84 = Reprojection::out_of(geo, "EPSG:4326").map_err(|why| {
        Error::input(
            source,
            format!("GeoJSON is in longitude and latitude (RFC 7946), and {why}"),
        )
    })?;
    let features = lines
        .iter()
        .map(|line| {
            let coordinates = line
                .cells
                .iter()
                .map(|&cell| {
                    let (x, y) = geo.center_of(cell);
                    let (lon, lat) = to_wgs84.point(x, y).map_err(|why| {
                        Error::input(source, format!("cell {cell} has no longitude: {why}"))
                    })?;
                    Ok(json!([lon, lat]))
                })
                .collect::<Result<Vec<Value>>>()?;
            Ok(json!({
                "type": "Feature",
                "properties": line.properties,
                "geometry": {"type": "LineString", "coordinates": coordinates},
            }))
        })
        .collect::<Result<Vec<Value>>>()?;
    let collection = json!({"type": "FeatureCollection", "features": features});
    Ok(serde_json::to_string(&collection).expect("GeoJSON serialises"))
}

/// Writes the FeatureCollection of `lines` on `geo` to `path`, atomically.
pub fn write_lines(path: &Path, geo: &GeoRef, lines: &[Line], source: &Path) -> Result<()> {
    let text = line_collection(geo, lines, source)?;
    write_bytes_atomic(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crs_members_name_epsg_codes_or_wgs84() {
        let crs = |name: &str| {
            legacy_crs(&json!({"crs": {"type": "name", "properties": {"name": name}}}))
        };
        assert_eq!(crs("urn:ogc:def:crs:EPSG::32632").unwrap(), "EPSG:32632");
        assert_eq!(crs("urn:ogc:def:crs:EPSG:6.6:2263").unwrap(), "EPSG:2263");
        assert_eq!(crs("EPSG:3857").unwrap(), "EPSG:3857");
        assert_eq!(crs("urn:ogc:def:crs:OGC:1.3:CRS84").unwrap(), GEOJSON_CRS);
        assert_eq!(legacy_crs(&json!({})).unwrap(), GEOJSON_CRS);
        assert!(crs("urn:ogc:def:crs:EPSG::").is_err());
    }

    #[test]
    fn points_alone_become_tracks_grouped_by_their_properties() {
        let point = |x: f64, properties: Value| {
            (
                json!({"type": "Point", "coordinates": [x, 1.0]}),
                properties,
            )
        };
        let collection = |features: Vec<(Value, Value)>| -> Vec<(usize, Value, Value)> {
            features
                .into_iter()
                .enumerate()
                .map(|(i, (g, p))| (i, g["coordinates"].clone(), p))
                .collect()
        };
        let read = |features: &[(usize, Value, Value)]| {
            let refs: Vec<(usize, &Value, &Value)> =
                features.iter().map(|(i, c, p)| (*i, c, p)).collect();
            point_tracks("fixes", &refs, Some("site"))
        };
        // Untimed points of no group: one track named after the file, timed by order.
        let plain = collection((0..3).map(|i| point(f64::from(i), json!({}))).collect());
        let tracks = read(&plain).unwrap();
        assert_eq!(tracks.len(), 1);
        assert_eq!(
            (tracks[0].episode.as_str(), tracks[0].map.as_str()),
            ("fixes", "site")
        );
        assert_eq!(tracks[0].poses[2].t, 2.0);
        // Grouped by `episode`, interleaved in the file.
        let grouped = collection(vec![
            point(0.0, json!({"episode": "a"})),
            point(1.0, json!({"episode": "b"})),
            point(2.0, json!({"episode": "a", "map": "elsewhere"})),
            point(3.0, json!({"episode": "b"})),
        ]);
        let tracks = read(&grouped).unwrap();
        let names: Vec<&str> = tracks.iter().map(|t| t.episode.as_str()).collect();
        assert_eq!(names, ["a", "b"]);
        assert_eq!(tracks[0].poses[1].x, 2.0);
        // A track of one point, and a time that is not one, say which.
        let lonely = collection(vec![point(0.0, json!({"episode": "a"}))]);
        assert!(read(&lonely).unwrap_err().contains("'a' has 1 point(s)"));
        let untimely = collection(vec![
            point(0.0, json!({"time": "soon"})),
            point(1.0, json!({"time": "later"})),
        ]);
        assert!(
            read(&untimely)
                .unwrap_err()
                .contains("feature 0: its time 'soon'")
        );
    }

    #[test]
    fn lines_become_episodes_named_by_their_properties() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("drawn.geojson");
        let write = |value: Value| std::fs::write(&path, value.to_string()).unwrap();
        write(json!({"type": "LineString", "coordinates": [[0, 0, 5], [3, 4, 6]]}));
        let bare = read_geojson_paths(&path, Some("site")).unwrap();
        assert_eq!(bare.demonstrations[0].episode, "drawn-000");
        assert_eq!(bare.demonstrations[0].poses[1].x, 3.0);
        write(json!({"type": "FeatureCollection", "features": [
            {"type": "Feature", "properties": {"episode": 7, "map": "other"},
             "geometry": {"type": "MultiLineString", "coordinates": [[[0, 0], [1, 1]], [[1, 1], [2, 0]]]}},
            {"type": "Feature", "properties": null, "geometry": {"type": "Point", "coordinates": [0, 0]}},
        ]}));
        let drawn = read_geojson_paths(&path, Some("site")).unwrap();
        let names: Vec<(&str, &str)> = drawn
            .demonstrations
            .iter()
            .map(|d| (d.episode.as_str(), d.map.as_str()))
            .collect();
        assert_eq!(names, [("7-0", "other"), ("7-1", "other")]);
        write(
            json!({"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": [[0, 0]]}}),
        );
        let why = read_geojson_paths(&path, Some("site"))
            .err()
            .unwrap()
            .to_string();
        assert!(
            why.contains("feature 0 ('drawn-000'), line 0: 1 vertex(es)"),
            "{why}"
        );
        write(json!({"type": "LineString", "coordinates": [[0, 0], [1, 1]]}));
        let why = read_geojson_paths(&path, None).err().unwrap().to_string();
        assert!(why.contains("no default map"), "{why}");
    }

    #[test]
    fn cell_centres_of_a_utm_map_go_out_as_longitude_and_latitude() {
        // 10 m cells of UTM 32N whose lower-left cell's centre is (500005, 5000005),
        // which PROJ 9 (rasterio) puts at 9.0000636° E, 45.1535222° N.
        let geo = GeoRef::square(4, 4, 10.0, [500000.0, 5000000.0], "EPSG:32632");
        let cells = [Cell::new(0, 0), Cell::new(1, 1)];
        let text = line_collection(
            &geo,
            &[Line {
                properties: json!({"kind": "plan"}),
                cells: &cells,
            }],
            Path::new("costmap"),
        )
        .unwrap();
        let value: Value = serde_json::from_str(&text).unwrap();
        let feature = &value["features"][0];
        assert_eq!(feature["properties"]["kind"], "plan");
        assert_eq!(feature["geometry"]["type"], "LineString");
        let first = &feature["geometry"]["coordinates"][0];
        let (lon, lat) = (first[0].as_f64().unwrap(), first[1].as_f64().unwrap());
        let (want_lon, want_lat) = (9.00006360955904, 45.153522191758945);
        assert!(
            (lon - want_lon).abs() < 1e-8 && (lat - want_lat).abs() < 1e-8,
            "{lon} {lat}"
        );
        let why = line_collection(&GeoRef::unit(4, 4), &[], Path::new("costmap"))
            .unwrap_err()
            .to_string();
        assert!(why.contains("RFC 7946") && why.contains("costmap"), "{why}");
    }
}
