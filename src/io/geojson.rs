//! Paths on a map as GeoJSON (RFC 7946), the vector format QGIS, geojson.io, Leaflet
//! and every GIS library open: a FeatureCollection of LineStrings through cell centres,
//! in WGS 84 longitude and latitude, as the RFC requires, moved there from the map's
//! CRS. Maps with no CRS have no place on the Earth and are refused.

use std::path::Path;

use serde_json::{Value, json};

use super::fs::write_bytes_atomic;
use crate::error::{Error, Result};
use crate::grid::{Cell, GeoRef, Reprojection};

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
