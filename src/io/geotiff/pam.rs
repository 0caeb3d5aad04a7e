//! GDAL's PAM sidecar (`<file>.aux.xml`): what GDAL keeps of a GeoTIFF that the TIFF
//! itself cannot hold. Read here for one thing: which bands it declares classes, as
//! land covers converted by `gdal_translate` or classified in QGIS carry them:
//! - a colour table (`<ColorTable>`) on a band that is not a palette image;
//! - category names (`<CategoryNames>`);
//! - a raster attribute table (`<GDALRasterAttributeTable>`) with a name or a colour
//!   per value (a string field, or a field of usage Name, Red, Green, Blue or Alpha).
//!   A table of values and counts alone is not enough: GDAL calls every table
//!   "thematic", and ArcGIS builds one for any integer raster, DEMs included.

use std::path::{Path, PathBuf};

use quick_xml::events::{BytesStart, Event};
use quick_xml::reader::Reader;

/// The sidecar GDAL reads beside `path`.
pub fn sidecar(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".aux.xml");
    PathBuf::from(name)
}

/// The bands (numbered from 0) that the sidecar of `path` declares classes; none where
/// there is no sidecar. A sidecar that cannot be read or parsed is left out with a
/// warning, as GDAL does.
pub(super) fn declared_class_bands(path: &Path) -> Vec<usize> {
    let sidecar = sidecar(path);
    let Ok(xml) = std::fs::read_to_string(&sidecar) else {
        return Vec::new();
    };
    match class_bands(&xml) {
        Ok(bands) => bands,
        Err(e) => {
            tracing::warn!(
                "{}: not read (its XML is malformed: {e}); its bands are read without it",
                sidecar.display()
            );
            Vec::new()
        }
    }
}

/// GDAL's field usages that give each value a name or a colour (GFU_Name, GFU_Red,
/// GFU_Green, GFU_Blue, GFU_Alpha), and its string field type (GFT_String).
const NAME_OR_COLOUR_USAGES: [&str; 5] = ["2", "6", "7", "8", "9"];
const STRING_TYPE: &str = "2";

/// The bands that a PAM document declares classes, numbered from 0, in ascending order.
fn class_bands(xml: &str) -> Result<Vec<usize>, quick_xml::Error> {
    let mut reader = Reader::from_str(xml);
    let mut bands = Vec::new();
    // The open <PAMRasterBand>'s number, whether it holds a <GDALRasterAttributeTable>,
    // the innermost open element's name, and the text read in it so far.
    let mut band: Option<usize> = None;
    let mut in_table = false;
    let mut element = Vec::new();
    let mut text = String::new();
    loop {
        match reader.read_event()? {
            Event::Eof => break,
            Event::Start(tag) => {
                match tag.name().as_ref() {
                    b"PAMRasterBand" => band = band_number(&tag),
                    b"GDALRasterAttributeTable" => in_table = true,
                    b"ColorTable" | b"CategoryNames" => declare(band, &mut bands),
                    _ => {}
                }
                element = tag.name().as_ref().to_vec();
                text.clear();
            }
            Event::Empty(tag) if tag.name().as_ref() == b"ColorTable" => declare(band, &mut bands),
            Event::Text(t) => text.push_str(&t.decode().map_err(quick_xml::Error::from)?),
            Event::End(tag) => {
                let value = text.trim();
                let name_or_colour = match element.as_slice() {
                    b"Type" => value == STRING_TYPE,
                    b"Usage" => NAME_OR_COLOUR_USAGES.contains(&value),
                    _ => false,
                };
                if in_table && name_or_colour {
                    declare(band, &mut bands);
                }
                match tag.name().as_ref() {
                    b"PAMRasterBand" => band = None,
                    b"GDALRasterAttributeTable" => in_table = false,
                    _ => {}
                }
                element.clear();
                text.clear();
            }
            _ => {}
        }
    }
    bands.sort_unstable();
    Ok(bands)
}

/// Adds the open band, if any, to `bands` once.
fn declare(band: Option<usize>, bands: &mut Vec<usize>) {
    if let Some(b) = band
        && !bands.contains(&b)
    {
        bands.push(b);
    }
}

/// A `<PAMRasterBand band="N">`'s band, numbered from 0 (GDAL numbers from 1).
fn band_number(tag: &BytesStart) -> Option<usize> {
    tag.attributes()
        .flatten()
        .find(|a| a.key.as_ref() == b"band")
        .and_then(|a| {
            std::str::from_utf8(&a.value)
                .ok()?
                .trim()
                .parse::<usize>()
                .ok()
        })
        .and_then(|n| n.checked_sub(1))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PAM document with one band holding `inner`.
    fn pam(inner: &str) -> String {
        format!(
            "<PAMDataset>\n  <PAMRasterBand band=\"1\">\n    <Metadata>\n      \
             <MDI key=\"STATISTICS_MAXIMUM\">44</MDI>\n    </Metadata>\n{inner}  \
             </PAMRasterBand>\n  <PAMRasterBand band=\"2\"/>\n</PAMDataset>\n"
        )
    }

    /// A raster attribute table of `fields` (name, type, usage), as GDAL writes it.
    fn table(fields: &[(&str, u8, u8)]) -> String {
        let mut xml = String::from("<GDALRasterAttributeTable tableType=\"thematic\">\n");
        for (i, (name, kind, usage)) in fields.iter().enumerate() {
            xml += &format!(
                "<FieldDefn index=\"{i}\"><Name>{name}</Name><Type>{kind}</Type>\
                 <Usage>{usage}</Usage></FieldDefn>\n"
            );
        }
        xml += "<Row index=\"0\"><F>1</F><F>10</F></Row>\n</GDALRasterAttributeTable>\n";
        xml
    }

    #[test]
    fn names_and_colours_declare_classes_and_counts_alone_do_not() {
        let categories =
            pam("<CategoryNames><Category/><Category>Urban</Category></CategoryNames>");
        assert_eq!(class_bands(&categories).unwrap(), [0]);
        let colours =
            pam("<ColorTable><Entry c1=\"0\" c2=\"0\" c3=\"0\" c4=\"255\"/></ColorTable>");
        assert_eq!(class_bands(&colours).unwrap(), [0]);
        let labels = pam(&table(&[
            ("Value", 0, 5),
            ("Count", 0, 1),
            ("LABEL3", 2, 2),
        ]));
        assert_eq!(class_bands(&labels).unwrap(), [0]);
        let red = pam(&table(&[("Value", 0, 5), ("Red", 0, 6)]));
        assert_eq!(class_bands(&red).unwrap(), [0]);
        // ArcGIS's table of an integer DEM, and statistics: no declaration.
        let counts = pam(&table(&[("Value", 0, 5), ("Count", 0, 1)]));
        assert!(class_bands(&counts).unwrap().is_empty());
        assert!(class_bands(&pam("")).unwrap().is_empty());
        // A usage "2" outside a table (statistics' text) declares nothing.
        assert!(class_bands(&pam("<Usage>2</Usage>\n")).unwrap().is_empty());
    }

    #[test]
    fn malformed_or_missing_sidecars_declare_nothing() {
        assert!(class_bands("<PAMDataset><PAMRasterBand band=\"1\"></Oops>").is_err());
        let dir = tempfile::tempdir().unwrap();
        let tif = dir.path().join("x.tif");
        assert!(declared_class_bands(&tif).is_empty());
        std::fs::write(
            sidecar(&tif),
            "<PAMDataset><PAMRasterBand band=\"1\"></Oops>",
        )
        .unwrap();
        assert!(declared_class_bands(&tif).is_empty());
        std::fs::write(
            sidecar(&tif),
            pam("<CategoryNames><Category>A</Category></CategoryNames>"),
        )
        .unwrap();
        assert_eq!(declared_class_bands(&tif), [0]);
    }
}
