//! GDAL's per-band scale and offset (the `GDAL_METADATA` tag's `role="scale"` and
//! `role="offset"` items), which turn stored integers into physical values: a DEM kept
//! as decimetres in int16 with scale 0.1 is metres only once scaled, and its slopes
//! are wrong by ten times otherwise.

use quick_xml::events::Event;
use quick_xml::reader::Reader;

/// GDAL's XML metadata tag.
pub(super) const GDAL_METADATA: u16 = 42112;

/// `(scale, offset)` of each of `bands` bands from the tag's XML: (1, 0) where it names
/// none. GDAL numbers the items' `sample` attribute from 0.
pub(super) fn scales_and_offsets(xml: &str, bands: usize) -> Result<Vec<(f64, f64)>, String> {
    let mut out = vec![(1.0, 0.0); bands];
    let mut reader = Reader::from_str(xml);
    // The role and sample of the <Item> whose text comes next.
    let mut item: Option<(String, Option<usize>)> = None;
    loop {
        match reader.read_event() {
            Err(e) => return Err(format!("its XML is malformed: {e}")),
            Ok(Event::Eof) => break,
            Ok(Event::Start(tag)) if tag.name().as_ref() == b"Item" => {
                let (mut role, mut sample) = (String::new(), None);
                for attribute in tag.attributes() {
                    let attribute = attribute.map_err(|e| format!("its XML is malformed: {e}"))?;
                    let value = attribute
                        .unescape_value()
                        .map_err(|e| format!("its XML is malformed: {e}"))?;
                    match attribute.key.as_ref() {
                        b"role" => role = value.into_owned(),
                        b"sample" => sample = value.trim().parse::<usize>().ok(),
                        _ => {}
                    }
                }
                item = Some((role, sample));
            }
            Ok(Event::Text(text)) => {
                let Some((role, sample)) = item.take() else {
                    continue;
                };
                if role != "scale" && role != "offset" {
                    continue;
                }
                let text = text
                    .decode()
                    .map_err(|e| format!("its XML is malformed: {e}"))?;
                let value: f64 = text.trim().parse().map_err(|_| {
                    format!(
                        "the {role} {:?} of sample {sample:?} is not a number",
                        text.trim()
                    )
                })?;
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
                    out[band].0 = value;
                } else {
                    out[band].1 = value;
                }
            }
            Ok(Event::End(_)) => item = None,
            Ok(_) => {}
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_gdal_scales_and_offsets_per_band() {
        let xml = r#"<GDALMetadata>
  <Item name="STATISTICS_MEAN" sample="0">12.5</Item>
  <Item name="OFFSET" sample="0" role="offset">-100</Item>
  <Item name="SCALE" sample="0" role="scale">0.1</Item>
  <Item name="SCALE" sample="2" role="scale">2.5E-2</Item>
  <Item name="AREA_OR_POINT">Area</Item>
</GDALMetadata>"#;
        let got = scales_and_offsets(xml, 3).unwrap();
        assert_eq!(got, vec![(0.1, -100.0), (1.0, 0.0), (0.025, 0.0)]);
        assert_eq!(
            scales_and_offsets("<GDALMetadata/>", 2).unwrap(),
            vec![(1.0, 0.0); 2]
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
            let e = scales_and_offsets(xml, 1).unwrap_err();
            assert!(e.contains(needle), "{xml}: {e}");
        }
    }
}
