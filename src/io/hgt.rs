//! SRTM height tiles (`.hgt`), as NASA, USGS EarthExplorer and viewfinderpanoramas hand
//! out the Shuttle Radar Topography Mission's DEM: one 1° × 1° tile of big-endian int16
//! heights in metres, rows from the north, 1201 × 1201 samples (3 arc-seconds) or
//! 3601 × 3601 (1 arc-second), -32768 where there is no data. The tile's south-west
//! corner is in its name (`N46E007.hgt`); samples are centred on the whole degrees, so the
//! grid reaches half a cell past them, as GDAL reads it. WGS 84 (EPSG:4326). A tile
//! zipped as NASA hands it out (`N46E007.SRTMGL1.hgt.zip`) is read as it is.

use std::path::Path;

use super::geotiff::{Georeferencing, georeference};
use crate::error::{Error, Result, open_input, read_input};
use crate::grid::{Layer, Map};

/// The GeoKeys of WGS 84 degrees (geographic model, PixelIsArea, EPSG:4326).
pub(super) const WGS84_KEYS: [u16; 16] =
    [1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 1, 2048, 0, 1, 4326];
const VOID: i16 = -32768;

/// The south-west corner (longitude, latitude) a tile's file name gives.
fn tile_corner(path: &Path) -> std::result::Result<(f64, f64), String> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_uppercase())
        .unwrap_or_default();
    let bad = || {
        format!(
            "an SRTM tile's name starts with its south-west corner, as N46E007 or S12W077; \
             '{name}' does not"
        )
    };
    let (ns, rest) = name.split_at_checked(1).ok_or_else(bad)?;
    let (lat, rest) = rest.split_at_checked(2).ok_or_else(bad)?;
    let (ew, rest) = rest.split_at_checked(1).ok_or_else(bad)?;
    let lon = rest.get(..3).ok_or_else(bad)?;
    let degrees = |digits: &str| {
        digits
            .bytes()
            .all(|b| b.is_ascii_digit())
            .then(|| digits.parse::<f64>().ok())
            .flatten()
            .ok_or_else(bad)
    };
    let (lat, lon) = (degrees(lat)?, degrees(lon)?);
    let lat = match ns {
        "N" => lat,
        "S" => -lat,
        _ => return Err(bad()),
    };
    let lon = match ew {
        "E" => lon,
        "W" => -lon,
        _ => return Err(bad()),
    };
    if lat.abs() > 89.0 || lon.abs() > 180.0 {
        return Err(format!("'{name}' names no tile on the Earth"));
    }
    Ok((lon, lat))
}

/// The SRTM tile at `path` as map `name`, its one layer `elevation`.
pub fn read_hgt(path: &Path, name: &str) -> Result<Map> {
    let bytes = read_input(path)?;
    read_tile(path, path, &bytes, name)
}

/// The SRTM tile zipped as NASA's LP DAAC and USGS EarthExplorer hand it out
/// (`N46E007.SRTMGL1.hgt.zip` holding `N46E007.hgt`), read without unzipping it, as GDAL
/// reads it; map `name`, its one layer `elevation`.
pub fn read_hgt_zip(path: &Path, name: &str) -> Result<Map> {
    let problem = |message: String| Error::input(path, message);
    let mut archive = zip::ZipArchive::new(open_input(path)?)
        .map_err(|e| problem(format!("is not a readable ZIP archive: {e}")))?;
    let names: Vec<String> = archive
        .file_names()
        .map(|n| n.map(|n| n.into_owned()))
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| problem(format!("is not a readable ZIP archive: {e}")))?;
    let tiles: Vec<&String> = names
        .iter()
        .filter(|n| n.to_ascii_lowercase().ends_with(".hgt"))
        .collect();
    let [tile] = &tiles[..] else {
        return Err(problem(format!(
            "a zipped SRTM tile holds one .hgt file; this archive holds {} ({}): unzip it \
             and name the tiles, or mosaic them with gdalbuildvrt",
            tiles.len(),
            tiles
                .iter()
                .map(|t| t.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    };
    let mut entry = archive
        .by_name(tile.as_str())
        .map_err(|e| problem(format!("{tile}: {e}")))?;
    // A tile is at most 3601² int16 samples: a larger entry is not one.
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(
        &mut std::io::Read::take(&mut entry, 2 * 3601 * 3601 + 1),
        &mut bytes,
    )
    .map_err(|e| problem(format!("{tile} cannot be unzipped: {e}")))?;
    let inside = path.join(tile.as_str());
    read_tile(path, &inside, &bytes, name)
}

/// A tile's heights `bytes`, read from `path` (named in errors), its corner from the
/// name of `tile`.
fn read_tile(path: &Path, tile: &Path, bytes: &[u8], name: &str) -> Result<Map> {
    let problem = |message: String| Error::input(path, message);
    let (lon, lat) = tile_corner(tile).map_err(problem)?;
    let side = [1201u32, 3601]
        .into_iter()
        .find(|&n| bytes.len() == 2 * n as usize * n as usize)
        .ok_or_else(|| {
            problem(format!(
                "{} bytes are not an SRTM tile's 1201 × 1201 or 3601 × 3601 int16 heights",
                bytes.len()
            ))
        })?;
    let n = side as usize;
    let cell = 1.0 / f64::from(side - 1);
    let (geo, _) = georeference(
        path,
        side,
        side,
        Georeferencing::of_grid(
            [
                cell,
                0.0,
                lon - cell / 2.0,
                0.0,
                -cell,
                lat + 1.0 + cell / 2.0,
            ],
            &WGS84_KEYS,
            String::new(),
        ),
    )?;
    // Rows from the north in the file; ours start from the south.
    let mut values = vec![f32::NAN; n * n];
    for (file_row, row) in bytes.chunks_exact(2 * n).enumerate() {
        let ours = &mut values[(n - 1 - file_row) * n..][..n];
        for (value, sample) in ours.iter_mut().zip(row.chunks_exact(2)) {
            let height = i16::from_be_bytes([sample[0], sample[1]]);
            if height != VOID {
                *value = f32::from(height);
            }
        }
    }
    if values.iter().all(|v| v.is_nan()) {
        return Err(problem("every sample is a void (-32768)".into()));
    }
    Ok(Map {
        name: name.to_string(),
        geo,
        layers: vec![Layer::new("elevation", values)],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tile_names_give_their_south_west_corner() {
        let corner = |name: &str| tile_corner(Path::new(name));
        assert_eq!(corner("N46E007.hgt"), Ok((7.0, 46.0)));
        assert_eq!(corner("dir/s12w077.hgt"), Ok((-77.0, -12.0)));
        assert_eq!(corner("N00W180.SRTMGL1.hgt"), Ok((-180.0, 0.0)));
        for bad in ["dem.hgt", "N4E007.hgt", "X46E007.hgt", "N46E07.hgt"] {
            assert!(corner(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn a_tile_reads_from_the_north_with_voids_as_nan() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("S01W001.hgt");
        let mut bytes = vec![0u8; 2 * 1201 * 1201];
        bytes[..2].copy_from_slice(&1234i16.to_be_bytes());
        bytes[2..4].copy_from_slice(&VOID.to_be_bytes());
        std::fs::write(&path, &bytes).unwrap();
        let map = read_hgt(&path, "tile").unwrap();
        let values = &map.layers[0].values;
        // The file's first sample is the north-west corner: our last row.
        assert_eq!(values[1200 * 1201], 1234.0);
        assert!(values[1200 * 1201 + 1].is_nan());
        let [west, south, east, north] = map.geo.bounds();
        let half = 0.5 / 1200.0;
        for (got, want) in [
            (west, -1.0 - half),
            (south, -1.0 - half),
            (east, half),
            (north, half),
        ] {
            assert!((got - want).abs() < 1e-9, "{got} {want}");
        }
        std::fs::write(&path, &bytes[..1000]).unwrap();
        let why = read_hgt(&path, "tile").unwrap_err().to_string();
        assert!(why.contains("1000 bytes are not an SRTM tile"), "{why}");
    }
}
