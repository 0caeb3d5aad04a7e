//! Esri ASCII grids (`.asc`), the text DEMs that national mapping agencies, LiDAR
//! portals and older GIS tools hand out: a header (`ncols`, `nrows`, `xllcorner` or
//! `xllcenter`, `yllcorner` or `yllcenter`, `cellsize` or GDAL's `dx` and `dy`, an
//! optional `NODATA_value`), then the values row by row from the north. The CRS is the
//! ESRI WKT of the `.prj` file beside it, read as GDAL reads it; without one, GDAL's
//! sidecar (`.asc.aux.xml`) may give it; with neither, coordinates are metres, as a
//! GeoTIFF without a CRS. The one band becomes layer `band1`, as GDAL names it.

use std::path::{Path, PathBuf};

use super::geotiff::{Georeferencing, georeference, sidecar, wkt_geokeys};
use crate::error::{Error, Result, read_input};
use crate::grid::{Layer, Map};

/// The files beside an ASCII grid that can give it its CRS: what reading it depends on.
pub fn ascii_grid_sidecars(path: &Path) -> Vec<PathBuf> {
    [path.with_extension("prj"), sidecar(path)]
        .into_iter()
        .filter(|f| f.is_file())
        .collect()
}

/// The header's values, by GDAL's names.
#[derive(Debug, PartialEq)]
struct Header {
    columns: u32,
    rows: u32,
    /// The lower-left corner of the lower-left cell.
    west: f64,
    south: f64,
    cell: [f64; 2],
    nodata: Option<f64>,
}

/// The ASCII grid at `path` as map `name`.
pub fn read_ascii_grid(path: &Path, name: &str) -> Result<Map> {
    let bytes = read_input(path)?;
    let problem = |message: String| Error::input(path, message);
    let text = std::str::from_utf8(&bytes)
        .map_err(|e| problem(format!("is not an ASCII grid (not text: {e})")))?;
    let mut tokens = text.split_ascii_whitespace().peekable();
    let header = read_header(&mut tokens).map_err(problem)?;
    let (width, height) = (header.columns as usize, header.rows as usize);
    // Every value takes two bytes at least (a digit and a space): a header that asks
    // for more cells than that is refused before their memory is taken.
    let cells = width
        .checked_mul(height)
        .filter(|&n| n <= bytes.len() / 2 + 1)
        .ok_or_else(|| {
            problem(format!(
                "its header gives {width} × {height} cells, more than its {} bytes can hold",
                bytes.len()
            ))
        })?;
    // Rows from the north in the file; ours start from the south.
    let mut values = vec![f32::NAN; cells];
    let mut count = 0usize;
    for token in tokens {
        if count == cells {
            return Err(problem(format!(
                "holds more than the {width} × {height} values its header gives"
            )));
        }
        let (file_row, col) = (count / width, count % width);
        let value: f64 = token.parse().map_err(|_| {
            problem(format!(
                "value {count} (row {file_row}, column {col} from the north-west): '{token}' \
                 is not a number"
            ))
        })?;
        if header.nodata != Some(value) && value.is_finite() {
            values[(height - 1 - file_row) * width + col] = value as f32;
        }
        count += 1;
    }
    if count < cells {
        return Err(problem(format!(
            "holds {count} values; its header gives {width} × {height} = {cells}"
        )));
    }
    let (keys, ascii) = crs_keys(path).map_err(problem)?;
    let [dx, dy] = header.cell;
    let (geo, heights) = georeference(
        path,
        header.columns,
        header.rows,
        Georeferencing::of_grid(
            [
                dx,
                0.0,
                header.west,
                0.0,
                -dy,
                header.south + dy * header.rows as f64,
            ],
            &keys,
            ascii,
        ),
    )?;
    if heights != 1.0 {
        values
            .iter_mut()
            .for_each(|v| *v = (f64::from(*v) * heights) as f32);
    }
    if values.iter().all(|v| v.is_nan()) {
        return Err(problem(format!(
            "every cell is nodata (NODATA_value {})",
            header.nodata.map_or("none".into(), |n| n.to_string())
        )));
    }
    Ok(Map {
        name: name.to_string(),
        geo,
        layers: vec![Layer::new("band1", values)],
    })
}

/// The header, consumed from `tokens` (keywords in any case, in any order, until the
/// first number that is not a keyword's value).
fn read_header<'a>(
    tokens: &mut std::iter::Peekable<impl Iterator<Item = &'a str>>,
) -> std::result::Result<Header, String> {
    let mut fields: Vec<(String, f64)> = Vec::new();
    while let Some(&keyword) = tokens.peek() {
        if keyword.parse::<f64>().is_ok() {
            break;
        }
        tokens.next();
        let keyword = keyword.to_ascii_lowercase();
        let value = tokens
            .next()
            .ok_or_else(|| format!("its header ends at '{keyword}', which has no value"))?;
        let value: f64 = value
            .parse()
            .map_err(|_| format!("its header's {keyword} is '{value}', not a number"))?;
        if fields.iter().any(|(k, _)| *k == keyword) {
            return Err(format!("its header gives {keyword} twice"));
        }
        fields.push((keyword, value));
    }
    let field = |name: &str| fields.iter().find(|(k, _)| k == name).map(|&(_, v)| v);
    let count = |name: &str| -> std::result::Result<u32, String> {
        let value = field(name).ok_or_else(|| {
            format!("is not an ASCII grid: its header has no {name} (ncols, nrows, xllcorner, yllcorner, cellsize)")
        })?;
        (value >= 1.0 && value.fract() == 0.0 && value <= f64::from(u32::MAX))
            .then_some(value as u32)
            .ok_or_else(|| format!("its header's {name} is {value}, not a count of cells"))
    };
    let (columns, rows) = (count("ncols")?, count("nrows")?);
    let cell = match (field("cellsize"), field("dx"), field("dy")) {
        (Some(size), None, None) => [size, size],
        (None, Some(dx), Some(dy)) => [dx, dy],
        _ => {
            return Err(
                "its header gives neither cellsize nor both dx and dy (and not both)".into(),
            );
        }
    };
    if !cell.iter().all(|s| s.is_finite() && *s > 0.0) {
        return Err(format!(
            "its cells of {} × {} are not a size",
            cell[0], cell[1]
        ));
    }
    let corner = |axis: &str, size: f64| match (
        field(&format!("{axis}llcorner")),
        field(&format!("{axis}llcenter")),
    ) {
        (Some(corner), None) => Ok(corner),
        (None, Some(centre)) => Ok(centre - size / 2.0),
        _ => Err(format!(
            "its header gives neither {axis}llcorner nor {axis}llcenter (or both)"
        )),
    };
    Ok(Header {
        columns,
        rows,
        west: corner("x", cell[0])?,
        south: corner("y", cell[1])?,
        cell,
        nodata: field("nodata_value"),
    })
}

/// The CRS as GeoKeys and the GeoAsciiParams they point into: from the `.prj` beside
/// the grid, else from its GDAL sidecar; none where neither names one.
pub(super) fn crs_keys(path: &Path) -> std::result::Result<(Vec<u16>, String), String> {
    let prj = path.with_extension("prj");
    let wkt = match std::fs::read_to_string(&prj) {
        Ok(wkt) => Some((wkt, prj)),
        Err(_) => {
            let pam = sidecar(path);
            std::fs::read_to_string(&pam)
                .ok()
                .and_then(|xml| srs_of_sidecar(&xml))
                .map(|wkt| (wkt, pam))
        }
    };
    let Some((wkt, from)) = wkt else {
        return Ok((Vec::new(), String::new()));
    };
    wkt_geokeys(wkt.trim()).ok_or_else(|| {
        format!(
            "the CRS in {} is neither a projected nor a geographic CRS in WKT",
            from.display()
        )
    })
}

/// The `<SRS>` text of a GDAL sidecar, if it has one.
fn srs_of_sidecar(xml: &str) -> Option<String> {
    let start = xml.find("<SRS")?;
    let body = &xml[start..];
    let open = body.find('>')? + 1;
    let close = body.find("</SRS>")?;
    let text = body.get(open..close)?;
    Some(
        text.replace("&quot;", "\"")
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&amp;", "&"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(text: &str) -> std::result::Result<Header, String> {
        read_header(&mut text.split_ascii_whitespace().peekable())
    }

    #[test]
    fn headers_as_gdal_and_esri_write_them() {
        let gdal = header(
            "ncols 4\nnrows 3\nxllcorner 400000\nyllcorner 5159970\ncellsize 10\nNODATA_value -9999\n0 1",
        );
        assert_eq!(
            gdal.unwrap(),
            Header {
                columns: 4,
                rows: 3,
                west: 400000.0,
                south: 5159970.0,
                cell: [10.0, 10.0],
                nodata: Some(-9999.0),
            }
        );
        let centres = header("NCOLS 2 NROWS 2 XLLCENTER 5 YLLCENTER 5 DX 2 DY 4 1 2 3 4").unwrap();
        assert_eq!(
            (centres.west, centres.south, centres.cell),
            (4.0, 3.0, [2.0, 4.0])
        );
        assert_eq!(centres.nodata, None);
    }

    #[test]
    fn broken_headers_are_explained() {
        for (text, says) in [
            ("nrows 3 xllcorner 0 yllcorner 0 cellsize 1 1", "no ncols"),
            (
                "ncols 2.5 nrows 3 xllcorner 0 yllcorner 0 cellsize 1",
                "not a count",
            ),
            (
                "ncols 2 nrows 3 xllcorner 0 yllcorner 0 1",
                "neither cellsize",
            ),
            (
                "ncols 2 nrows 3 yllcorner 0 cellsize 1 1",
                "neither xllcorner",
            ),
            (
                "ncols 2 nrows 3 xllcorner 0 yllcorner 0 cellsize -1 1",
                "not a size",
            ),
            ("ncols 2 nrows 3 ncols 2", "twice"),
            ("ncols 2 nrows x", "'x', not a number"),
        ] {
            let why = header(text).unwrap_err();
            assert!(why.contains(says), "{text}: {why}");
        }
    }

    #[test]
    fn values_fill_the_grid_from_the_north_with_nodata_as_nan() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("dem.asc");
        std::fs::write(
            &path,
            "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 5\nNODATA_value -9999\n1 -9999.0\n3 4.5\n",
        )
        .unwrap();
        let map = read_ascii_grid(&path, "dem").unwrap();
        let values = &map.layers[0].values;
        assert_eq!((values[0], values[1], values[2]), (3.0, 4.5, 1.0));
        assert!(values[3].is_nan());
        assert_eq!(map.geo.bounds(), [0.0, 0.0, 10.0, 10.0]);
        std::fs::write(
            &path,
            "ncols 2 nrows 2 xllcorner 0 yllcorner 0 cellsize 5 1 2 3",
        )
        .unwrap();
        let why = read_ascii_grid(&path, "dem").unwrap_err().to_string();
        assert!(
            why.contains("dem.asc") && why.contains("holds 3 values"),
            "{why}"
        );
        std::fs::write(
            &path,
            "ncols 2 nrows 1 xllcorner 0 yllcorner 0 cellsize 5 1 x",
        )
        .unwrap();
        let why = read_ascii_grid(&path, "dem").unwrap_err().to_string();
        assert!(why.contains("value 1 (row 0, column 1"), "{why}");
    }
}
