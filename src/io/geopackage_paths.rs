//! Paths drawn in QGIS as it saves a new line layer by default: a GeoPackage (`.gpkg`)
//! of LineStrings and MultiLineStrings, GDAL's OGR writing it.
//!
//! Every layer of features holding lines is read, in the order of their names, each
//! feature in the order of its key: every LineString, and every part of a
//! MultiLineString, an episode from its first vertex to its last, on the map its `map`
//! column names or the default map, named by its `episode` or `name` column (else
//! `<layer>-NNN`). Coordinates are in the layer's CRS (`gpkg_spatial_ref_sys`, an EPSG
//! code), moved into the map's by the caller. Geometries are GeoPackage binary: a
//! `GP` header (its envelope skipped) before ISO or extended WKB, with or without Z
//! and M (dropped).

use std::path::Path;

use rusqlite::Connection;
use rusqlite::types::ValueRef;

use super::geojson::{DrawnFeature, DrawnPaths, warn_of_passed_over};
use super::sqlite_tiles::{has_tables, open_sqlite, quoted};
use crate::error::{Error, Result};
use crate::grid::Demonstration;

/// A layer of features and its geometry column, as `gpkg_geometry_columns` gives it.
struct Layer {
    table: String,
    geometry: String,
    srs_id: i64,
}

/// The paths of every line layer of the GeoPackage at `path`, one [`DrawnPaths`] per
/// layer (each layer has its own CRS), on the map a feature's `map` column names or
/// else `default_map`.
pub fn read_geopackage_paths(path: &Path, default_map: Option<&str>) -> Result<Vec<DrawnPaths>> {
    let problem = |message: String| Error::input(path, message);
    let db = open_sqlite(path, "a GeoPackage")?;
    let layers = feature_layers(&db).map_err(&problem)?;
    let mut read = Vec::new();
    let mut passed_over = 0;
    for layer in &layers {
        let at = |message: String| problem(format!("layer {}: {message}", layer.table));
        let (demonstrations, others) = layer_paths(&db, layer, default_map).map_err(at)?;
        passed_over += others;
        if demonstrations.is_empty() {
            continue;
        }
        let crs = layer_crs(&db, layer.srs_id).map_err(at)?;
        read.push(DrawnPaths {
            demonstrations,
            crs,
        });
    }
    warn_of_passed_over(path, passed_over);
    if read.is_empty() {
        let names: Vec<&str> = layers.iter().map(|l| l.table.as_str()).collect();
        return Err(problem(format!(
            "holds no LineString or MultiLineString (paths are lines) in its layers of \
             features ({})",
            if names.is_empty() {
                "it has none".to_string()
            } else {
                names.join(", ")
            }
        )));
    }
    Ok(read)
}

/// The layers of features, by name.
fn feature_layers(db: &Connection) -> std::result::Result<Vec<Layer>, String> {
    if !has_tables(db, &["gpkg_contents", "gpkg_geometry_columns"])? {
        return Err(
            "it is not a GeoPackage of features (it has no gpkg_contents and \
                    gpkg_geometry_columns tables)"
                .into(),
        );
    }
    let unreadable = |e: rusqlite::Error| format!("its layers cannot be listed: {e}");
    let mut statement = db
        .prepare(
            "SELECT c.table_name, g.column_name, g.srs_id FROM gpkg_contents c \
             JOIN gpkg_geometry_columns g ON c.table_name = g.table_name \
             WHERE c.data_type = 'features' ORDER BY c.table_name",
        )
        .map_err(unreadable)?;
    statement
        .query_map([], |r| {
            Ok(Layer {
                table: r.get(0)?,
                geometry: r.get(1)?,
                srs_id: r.get(2)?,
            })
        })
        .and_then(Iterator::collect)
        .map_err(unreadable)
}

/// A layer's CRS as `EPSG:<code>`.
fn layer_crs(db: &Connection, srs_id: i64) -> std::result::Result<String, String> {
    let (organization, code): (String, i64) = db
        .query_row(
            "SELECT organization, organization_coordsys_id FROM gpkg_spatial_ref_sys \
             WHERE srs_id = ?1",
            [srs_id],
            |r| Ok((r.get(0)?, r.get(1)?)),
        )
        .map_err(|e| format!("its CRS (srs_id {srs_id}) cannot be read: {e}"))?;
    if organization.eq_ignore_ascii_case("EPSG") && code > 0 {
        Ok(format!("EPSG:{code}"))
    } else {
        Err(format!(
            "its CRS (srs_id {srs_id}) is {organization} {code}, not an EPSG code: save \
             the layer in the map's CRS or in WGS 84"
        ))
    }
}

/// The episodes of one layer, and how many of its features are not lines.
fn layer_paths(
    db: &Connection,
    layer: &Layer,
    default_map: Option<&str>,
) -> std::result::Result<(Vec<Demonstration>, usize), String> {
    let unreadable = |e: rusqlite::Error| format!("its features cannot be read: {e}");
    let columns: Vec<String> = db
        .prepare(&format!("PRAGMA table_info({})", quoted(&layer.table)))
        .and_then(|mut s| s.query_map([], |r| r.get(1))?.collect())
        .map_err(unreadable)?;
    // The optional label columns, found whatever their case.
    let label = |wanted: &str| {
        columns
            .iter()
            .find(|c| c.eq_ignore_ascii_case(wanted))
            .map(|c| quoted(c))
            .unwrap_or_else(|| "NULL".into())
    };
    let mut statement = db
        .prepare(&format!(
            "SELECT {}, {}, {}, {} FROM {} ORDER BY rowid",
            quoted(&layer.geometry),
            label("episode"),
            label("name"),
            label("map"),
            quoted(&layer.table)
        ))
        .map_err(unreadable)?;
    let mut rows = statement.query([]).map_err(unreadable)?;
    let mut demonstrations = Vec::new();
    let mut passed_over = 0;
    let mut index = 0;
    while let Some(row) = rows.next().map_err(unreadable)? {
        let feature = index;
        index += 1;
        let text = |i: usize| match row.get_ref(i) {
            Ok(ValueRef::Text(t)) => {
                Some(String::from_utf8_lossy(t).trim().to_string()).filter(|t| !t.is_empty())
            }
            Ok(ValueRef::Integer(n)) => Some(n.to_string()),
            Ok(ValueRef::Real(x)) => Some(x.to_string()),
            _ => None,
        };
        let parts = match row.get_ref(0) {
            Ok(ValueRef::Blob(blob)) => {
                lines(blob).map_err(|why| format!("feature {feature}: {why}"))?
            }
            _ => None,
        };
        let Some(parts) = parts else {
            passed_over += 1;
            continue;
        };
        let drawn = DrawnFeature {
            index: feature,
            name: text(1)
                .or_else(|| text(2))
                .unwrap_or_else(|| format!("{}-{feature:03}", layer.table)),
            map: text(3),
        };
        demonstrations.extend(drawn.episodes(&parts, default_map)?);
    }
    Ok((demonstrations, passed_over))
}

/// The lines of a GeoPackage geometry: a LineString's vertices, or every part of a
/// MultiLineString; `None` for an empty geometry or one that is not a line.
fn lines(blob: &[u8]) -> std::result::Result<Option<Vec<Vec<[f64; 2]>>>, String> {
    if blob.len() < 8 || &blob[..2] != b"GP" {
        return Err("its geometry is not GeoPackage binary (no 'GP' header)".into());
    }
    let flags = blob[3];
    let envelope = match (flags >> 1) & 0b111 {
        0 => 0,
        1 => 32,
        2 | 3 => 48,
        4 => 64,
        code => return Err(format!("its geometry header has envelope code {code}")),
    };
    if flags & 0b1_0000 != 0 {
        return Ok(None);
    }
    let mut wkb = Wkb {
        bytes: blob,
        at: 8 + envelope,
    };
    let (kind, dimensions, little) = wkb.header()?;
    match kind {
        2 => Ok(Some(vec![wkb.points(dimensions, little)?])),
        5 => {
            let count = wkb.count(little)?;
            let mut parts = Vec::new();
            for _ in 0..count {
                let (kind, dimensions, little) = wkb.header()?;
                if kind != 2 {
                    return Err(format!(
                        "a part of its MultiLineString is WKB type {kind}, not a LineString"
                    ));
                }
                parts.push(wkb.points(dimensions, little)?);
            }
            Ok(Some(parts))
        }
        _ => Ok(None),
    }
}

/// Well-known binary, read from `at`.
struct Wkb<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Wkb<'_> {
    fn take<const N: usize>(&mut self) -> std::result::Result<[u8; N], String> {
        let bytes = self
            .bytes
            .get(self.at..self.at + N)
            .ok_or("its geometry ends early")?;
        self.at += N;
        Ok(bytes.try_into().expect("N bytes"))
    }

    fn count(&mut self, little: bool) -> std::result::Result<usize, String> {
        let bytes = self.take::<4>()?;
        let n = if little {
            u32::from_le_bytes(bytes)
        } else {
            u32::from_be_bytes(bytes)
        };
        Ok(n as usize)
    }

    /// A geometry's byte order, base type (2 a LineString, 5 a MultiLineString) and
    /// coordinates per vertex: ISO codes (1002, 2002, 3002 with Z, M, both) or the
    /// extended high bits (0x80000000 Z, 0x40000000 M).
    fn header(&mut self) -> std::result::Result<(u32, usize, bool), String> {
        let [order] = self.take::<1>()?;
        let little = match order {
            0 => false,
            1 => true,
            other => return Err(format!("its WKB byte order is {other}")),
        };
        let code = self.count(little)? as u32;
        let (z, m) = (code & 0x8000_0000 != 0, code & 0x4000_0000 != 0);
        let iso = code & 0x0FFF_FFFF;
        let (kind, thousands) = (iso % 1000, iso / 1000);
        let (z, m) = (z || thousands == 1 || thousands == 3, m || thousands >= 2);
        Ok((kind, 2 + usize::from(z) + usize::from(m), little))
    }

    /// A LineString's vertices (x, y), its Z and M dropped.
    fn points(
        &mut self,
        dimensions: usize,
        little: bool,
    ) -> std::result::Result<Vec<[f64; 2]>, String> {
        let count = self.count(little)?;
        let left = (self.bytes.len() - self.at.min(self.bytes.len())) / (8 * dimensions);
        if count > left {
            return Err(format!(
                "its line has {count} vertices, more than its geometry holds"
            ));
        }
        let mut number = || -> std::result::Result<f64, String> {
            let bytes = self.take::<8>()?;
            Ok(if little {
                f64::from_le_bytes(bytes)
            } else {
                f64::from_be_bytes(bytes)
            })
        };
        (0..count)
            .map(|_| {
                let vertex = [number()?, number()?];
                for _ in 2..dimensions {
                    number()?;
                }
                Ok(vertex)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry(envelope: u8, wkb: &[u8]) -> Vec<u8> {
        let mut blob = vec![b'G', b'P', 0, 1 | (envelope << 1)];
        blob.extend(4326i32.to_le_bytes());
        blob.extend(vec![0u8; [0, 32, 48, 48, 64][usize::from(envelope)]]);
        blob.extend(wkb);
        blob
    }

    fn line(code: u32, little: bool, vertices: &[&[f64]]) -> Vec<u8> {
        let mut wkb = vec![u8::from(little)];
        let word = |n: u32| {
            if little {
                n.to_le_bytes()
            } else {
                n.to_be_bytes()
            }
        };
        wkb.extend(word(code));
        wkb.extend(word(vertices.len() as u32));
        for vertex in vertices {
            for &x in *vertex {
                wkb.extend(if little {
                    x.to_le_bytes()
                } else {
                    x.to_be_bytes()
                });
            }
        }
        wkb
    }

    #[test]
    fn lines_are_read_in_either_byte_order_with_z_and_m_dropped() {
        let plain = geometry(1, &line(2, true, &[&[1.0, 2.0], &[3.0, 4.0]]));
        assert_eq!(
            lines(&plain).unwrap(),
            Some(vec![vec![[1.0, 2.0], [3.0, 4.0]]])
        );
        let zm = geometry(
            4,
            &line(3002, false, &[&[1.0, 2.0, 9.0, 8.0], &[3.0, 4.0, 9.0, 8.0]]),
        );
        assert_eq!(
            lines(&zm).unwrap(),
            Some(vec![vec![[1.0, 2.0], [3.0, 4.0]]])
        );
        let extended = geometry(
            0,
            &line(0x8000_0002, true, &[&[5.0, 6.0, 1.0], &[7.0, 8.0, 1.0]]),
        );
        assert_eq!(
            lines(&extended).unwrap(),
            Some(vec![vec![[5.0, 6.0], [7.0, 8.0]]])
        );

        let mut multi = vec![1u8];
        multi.extend(5u32.to_le_bytes());
        multi.extend(2u32.to_le_bytes());
        multi.extend(line(2, true, &[&[0.0, 0.0], &[1.0, 1.0]]));
        multi.extend(line(2, false, &[&[1.0, 1.0], &[2.0, 0.0]]));
        let parts = lines(&geometry(1, &multi)).unwrap().unwrap();
        assert_eq!(parts.len(), 2);
        assert_eq!(parts[1], [[1.0, 1.0], [2.0, 0.0]]);

        // A point is not a line; an empty geometry neither.
        let mut point = vec![1u8];
        point.extend(1u32.to_le_bytes());
        point.extend([0u8; 16]);
        assert_eq!(lines(&geometry(0, &point)).unwrap(), None);
        let mut empty = geometry(0, &line(2, true, &[]));
        empty[3] |= 0b1_0000;
        assert_eq!(lines(&empty).unwrap(), None);
    }

    #[test]
    fn damaged_geometries_are_errors_not_panics() {
        let good = geometry(1, &line(2, true, &[&[1.0, 2.0], &[3.0, 4.0]]));
        for cut in 0..good.len() {
            assert!(lines(&good[..cut]).is_err(), "cut at {cut}");
        }
        let mut huge = good.clone();
        huge[8 + 32 + 5..8 + 32 + 9].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(
            lines(&huge)
                .unwrap_err()
                .contains("more than its geometry holds")
        );
        let mut odd = good;
        odd[3] = 1 | (7 << 1);
        assert!(lines(&odd).unwrap_err().contains("envelope code 7"));
    }
}
