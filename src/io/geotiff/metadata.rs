//! GDAL's per-band metadata (the `GDAL_METADATA` tag's items):
//! - scale and offset (`role="scale"`, `role="offset"`), which turn stored integers
//!   into physical values: a DEM kept as decimetres in int16 with scale 0.1 is metres
//!   only once scaled, and its slopes are wrong by ten times otherwise;
//! - the description (`role="description"`, rasterio's `descriptions`), which names
//!   what a band holds ("elevation", "nir") and so becomes its layer's name;
//! - the unit (`role="unittype"`, rasterio's `units`): a DEM's heights in feet or
//!   centimetres become metres, as its slopes are measured in metres.

use quick_xml::events::Event;
use quick_xml::reader::Reader;

/// GDAL's XML metadata tag.
pub(super) const GDAL_METADATA: u16 = 42112;

/// What GDAL's metadata says of one band.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct BandMetadata {
    pub scale: f64,
    pub offset: f64,
    /// Trimmed; `None` where empty or absent.
    pub description: Option<String>,
    /// The band's unit as written (trimmed; `None` where empty or absent).
    pub unit: Option<String>,
}

impl Default for BandMetadata {
    fn default() -> Self {
        BandMetadata {
            scale: 1.0,
            offset: 0.0,
            description: None,
            unit: None,
        }
    }
}

/// The metadata of each of `bands` bands from the tag's XML: scale 1, offset 0 and no
/// description where it names none. GDAL numbers the items' `sample` attribute from 0.
pub(super) fn per_band(xml: &str, bands: usize) -> Result<Vec<BandMetadata>, String> {
    let mut out = vec![BandMetadata::default(); bands];
    let malformed = |e: &dyn std::fmt::Display| format!("its XML is malformed: {e}");
    let mut reader = Reader::from_str(xml);
    // The role and sample of the open <Item>, and its text so far (quick-xml reports
    // text and entity references such as `&amp;` as separate events).
    let mut item: Option<(String, Option<usize>, String)> = None;
    loop {
        match reader.read_event() {
            Err(e) => return Err(malformed(&e)),
            Ok(Event::Eof) => break,
            Ok(Event::Start(tag)) if tag.name().as_ref() == b"Item" => {
                let (mut role, mut sample) = (String::new(), None);
                for attribute in tag.attributes() {
                    let attribute = attribute.map_err(|e| malformed(&e))?;
                    let value = attribute.unescape_value().map_err(|e| malformed(&e))?;
                    match attribute.key.as_ref() {
                        b"role" => role = value.into_owned(),
                        b"sample" => sample = value.trim().parse::<usize>().ok(),
                        _ => {}
                    }
                }
                item = Some((role, sample, String::new()));
            }
            Ok(Event::Text(text)) => {
                if let Some((_, _, so_far)) = &mut item {
                    so_far.push_str(&text.decode().map_err(|e| malformed(&e))?);
                }
            }
            Ok(Event::GeneralRef(reference)) => {
                if let Some((_, _, so_far)) = &mut item {
                    match reference.resolve_char_ref().map_err(|e| malformed(&e))? {
                        Some(c) => so_far.push(c),
                        None => {
                            let name = reference.decode().map_err(|e| malformed(&e))?;
                            let text = quick_xml::escape::resolve_xml_entity(&name)
                                .ok_or_else(|| malformed(&format!("unknown entity &{name};")))?;
                            so_far.push_str(text);
                        }
                    }
                }
            }
            Ok(Event::End(_)) => {
                if let Some((role, sample, text)) = item.take() {
                    // GDAL escapes an item's value once more before the XML escapes it
                    // (its "&" is "&amp;amp;" in the file), and unescapes it twice;
                    // a value written by hand with one escape is taken as it is.
                    let text = match quick_xml::escape::unescape(&text) {
                        Ok(once_more) => once_more.into_owned(),
                        Err(_) => text,
                    };
                    apply_item(&mut out, &role, sample, text.trim())?;
                }
            }
            Ok(_) => {}
        }
    }
    Ok(out)
}

/// Metres per unit, for a band unit that is a length ("m", "ft", "US survey foot",
/// "cm", as people and GDAL write them; any case); `None` for any other unit
/// (reflectance, degrees, kelvin), which leaves the values as they are.
pub(crate) fn metres_per_unit(unit: &str) -> Option<f64> {
    let unit = unit.trim().to_ascii_lowercase().replace(['_', '-'], " ");
    Some(match unit.as_str() {
        "m" | "metre" | "metres" | "meter" | "meters" => 1.0,
        "ft" | "foot" | "feet" | "international foot" | "international feet" => 0.3048,
        "us survey foot" | "us survey feet" | "survey foot" | "us ft" | "ftus" | "ft us" => {
            1200.0 / 3937.0
        }
        "km" | "kilometre" | "kilometres" | "kilometer" | "kilometers" => 1000.0,
        "dm" | "decimetre" | "decimetres" | "decimeter" | "decimeters" => 0.1,
        "cm" | "centimetre" | "centimetres" | "centimeter" | "centimeters" => 0.01,
        "mm" | "millimetre" | "millimetres" | "millimeter" | "millimeters" => 0.001,
        _ => return None,
    })
}

/// The layer name of each band: its description where every band's is a usable,
/// distinct name, else `band1`, `band2`, ... A name is usable when it is at most 64
/// characters with no '/' (the separator of feature names) or control character, and
/// is not another band's number.
pub(crate) fn layer_names(bands: &[BandMetadata]) -> Vec<String> {
    let numbered = |band: usize| format!("band{}", band + 1);
    let usable = |band: usize, name: &str| {
        name.chars().count() <= 64
            && !name.contains('/')
            && !name.chars().any(char::is_control)
            && (name == numbered(band)
                || !(1..=bands.len()).any(|other| name == numbered(other - 1)))
    };
    let names: Vec<String> = bands
        .iter()
        .enumerate()
        .map(|(band, b)| match &b.description {
            Some(name) if usable(band, name) => name.clone(),
            _ => numbered(band),
        })
        .collect();
    let distinct = names
        .iter()
        .enumerate()
        .all(|(i, n)| !names[..i].contains(n));
    if distinct {
        names
    } else {
        (0..bands.len()).map(numbered).collect()
    }
}

/// Sets what one `<Item>` of role `role` for band `sample` says.
fn apply_item(
    out: &mut [BandMetadata],
    role: &str,
    sample: Option<usize>,
    text: &str,
) -> Result<(), String> {
    let bands = out.len();
    match role {
        // A description or unit of a band the raster lacks says nothing.
        "description" | "unittype" => {
            if let Some(band) = sample.filter(|&s| s < bands && !text.is_empty()) {
                let value = Some(text.to_string());
                if role == "description" {
                    out[band].description = value;
                } else {
                    out[band].unit = value;
                }
            }
        }
        "scale" | "offset" => {
            let value: f64 = text
                .parse()
                .map_err(|_| format!("the {role} {text:?} of sample {sample:?} is not a number"))?;
            if !value.is_finite() || (role == "scale" && value == 0.0) {
                return Err(format!(
                    "the {role} {value} of sample {sample:?} is not usable"
                ));
            }
            let Some(band) = sample.filter(|&s| s < bands) else {
                return Err(format!(
                    "a {role} for sample {sample:?}, but the raster has {bands} bands"
                ));
            };
            if role == "scale" {
                out[band].scale = value;
            } else {
                out[band].offset = value;
            }
        }
        _ => {}
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_gdal_scales_offsets_and_descriptions_per_band() {
        let xml = r#"<GDALMetadata>
  <Item name="STATISTICS_MEAN" sample="0">12.5</Item>
  <Item name="OFFSET" sample="0" role="offset">-100</Item>
  <Item name="SCALE" sample="0" role="scale">0.1</Item>
  <Item name="SCALE" sample="2" role="scale">2.5E-2</Item>
  <Item name="DESCRIPTION" sample="1" role="description"> Near infrared &amp;amp; more </Item>
  <Item name="DESCRIPTION" sample="0" role="description">Red &amp; &#x3C;ours&#62;</Item>
  <Item name="DESCRIPTION" sample="2" role="description">  </Item>
  <Item name="DESCRIPTION" sample="7" role="description">nothing</Item>
  <Item name="AREA_OR_POINT">Area</Item>
</GDALMetadata>"#;
        let got = per_band(xml, 3).unwrap();
        let band = |scale, offset, description: Option<&str>| BandMetadata {
            scale,
            offset,
            description: description.map(String::from),
            unit: None,
        };
        assert_eq!(
            got,
            vec![
                band(0.1, -100.0, Some("Red & <ours>")),
                band(1.0, 0.0, Some("Near infrared & more")),
                band(0.025, 0.0, None)
            ]
        );
        assert_eq!(
            per_band("<GDALMetadata/>", 2).unwrap(),
            vec![BandMetadata::default(); 2]
        );
    }

    #[test]
    fn band_units_that_are_lengths_are_measured_in_metres() {
        let xml = r#"<GDALMetadata>
  <Item name="UNITTYPE" sample="0" role="unittype">US survey foot</Item>
  <Item name="UNITTYPE" sample="1" role="unittype">W/m2</Item>
</GDALMetadata>"#;
        let bands = per_band(xml, 2).unwrap();
        assert_eq!(bands[0].unit.as_deref(), Some("US survey foot"));
        assert_eq!(metres_per_unit("US survey foot"), Some(1200.0 / 3937.0));
        assert_eq!(metres_per_unit("us-ft"), Some(1200.0 / 3937.0));
        assert_eq!(metres_per_unit(bands[1].unit.as_deref().unwrap()), None);
        for (unit, metres) in [("m", 1.0), ("Metres", 1.0), ("ft", 0.3048), ("cm", 0.01)] {
            assert_eq!(metres_per_unit(unit), Some(metres), "{unit}");
        }
        for other in ["degrees", "K", "reflectance", ""] {
            assert_eq!(metres_per_unit(other), None, "{other}");
        }
    }

    #[test]
    fn bands_are_named_by_their_descriptions_where_they_can_be() {
        let bands = |descriptions: &[Option<&str>]| -> Vec<BandMetadata> {
            descriptions
                .iter()
                .map(|d| BandMetadata {
                    description: d.map(String::from),
                    ..BandMetadata::default()
                })
                .collect()
        };
        assert_eq!(
            layer_names(&bands(&[Some("elevation"), None, Some("Near infrared")])),
            ["elevation", "band2", "Near infrared"]
        );
        // A band's own number is its name anyway; another band's is not.
        assert_eq!(
            layer_names(&bands(&[Some("band1"), Some("band1"), Some("x/y")])),
            ["band1", "band2", "band3"]
        );
        assert_eq!(
            layer_names(&bands(&[Some("band2"), None])),
            ["band1", "band2"]
        );
        // Two bands of one name: every band is numbered, so no name is ambiguous.
        assert_eq!(
            layer_names(&bands(&[Some("red"), Some("red"), Some("nir")])),
            ["band1", "band2", "band3"]
        );
    }

    #[test]
    fn unusable_scales_are_errors() {
        for (xml, needle) in [
            (
                r#"<GDALMetadata><Item sample="0" role="scale">ten</Item></GDALMetadata>"#,
                "not a number",
            ),
            (
                r#"<GDALMetadata><Item sample="0" role="scale">0</Item></GDALMetadata>"#,
                "not usable",
            ),
            (
                r#"<GDALMetadata><Item sample="4" role="offset">1</Item></GDALMetadata>"#,
                "1 bands",
            ),
            (
                r#"<GDALMetadata><Item sample="0" role="scale">1</Itm></GDALMetadata>"#,
                "malformed",
            ),
        ] {
            let e = per_band(xml, 1).unwrap_err();
            assert!(e.contains(needle), "{xml}: {e}");
        }
    }
}
