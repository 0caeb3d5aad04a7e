//! Paths as KML (`.kml`) or KMZ (`.kmz`, the KML zipped with what it references): the
//! routes people draw in Google Earth and Google My Maps, and the tracks phones and
//! loggers record in Google Earth's `gx:Track`. Every `LineString` of a `Placemark`
//! (inside a `MultiGeometry` too) is an episode from its first vertex to its last,
//! timed by their order; every `gx:Track` (and each of a `gx:MultiTrack`'s) is one
//! timed by its `<when>`s, as a GPX track by its `<time>`s. A placemark is named by its
//! `<name>`, its map by an `ExtendedData` field `map`; points and polygons are passed
//! over. Coordinates are WGS 84 longitude and latitude, as KML fixes them.

use std::io::Read;
use std::path::Path;

use quick_xml::events::Event;
use quick_xml::reader::Reader;

use super::geojson::{DrawnFeature, DrawnPaths};
use super::gpx::{Fix, parse_time, timed_poses};
use crate::error::{Error, Result, read_input};
use crate::grid::Demonstration;

/// The CRS of every KML file's coordinates (KML fixes WGS 84).
pub const KML_CRS: &str = "EPSG:4326";

/// What one `Placemark` holds.
#[derive(Default)]
struct Placemark {
    name: Option<String>,
    map: Option<String>,
    /// Its `LineString`s' vertices.
    lines: Vec<Vec<[f64; 2]>>,
    /// Its `gx:Track`s: positions and `<when>` texts.
    tracks: Vec<(Vec<[f64; 2]>, Vec<String>)>,
}

/// The paths of the KML or KMZ file at `path`, on the map each placemark's `map` field
/// names or else `default_map`. Episodes are named by their placemark's `<name>`, else
/// `<stem>-NNN` (its index), with `-K` for its lines after the first of several.
pub fn read_kml_paths(path: &Path, default_map: Option<&str>) -> Result<DrawnPaths> {
    let problem = |message: String| Error::input(path, message);
    let bytes = read_input(path)?;
    let documents = if bytes.starts_with(b"PK") {
        kmz_documents(&bytes).map_err(&problem)?
    } else {
        vec![("".to_string(), bytes)]
    };
    let mut placemarks = Vec::new();
    for (name, document) in documents {
        let within = |why: String| {
            if name.is_empty() {
                problem(why)
            } else {
                problem(format!("its {name} {why}"))
            }
        };
        let text = std::str::from_utf8(&document)
            .map_err(|e| within(format!("is not UTF-8 text (KML is XML): {e}")))?;
        placemarks.extend(parse_placemarks(text).map_err(within)?);
    }
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut demonstrations = Vec::new();
    let mut passed_over = 0;
    for (index, placemark) in placemarks.into_iter().enumerate() {
        if placemark.lines.is_empty() && placemark.tracks.is_empty() {
            passed_over += 1;
            continue;
        }
        let feature = DrawnFeature {
            index,
            name: placemark
                .name
                .unwrap_or_else(|| format!("{stem}-{index:03}")),
            map: placemark.map,
        };
        let mut episodes = if placemark.lines.is_empty() {
            Vec::new()
        } else {
            feature
                .episodes(&placemark.lines, default_map)
                .map_err(&problem)?
        };
        for (positions, whens) in &placemark.tracks {
            let track = timed_track(&feature, positions, whens, default_map).map_err(|why| {
                problem(format!(
                    "placemark {index} ('{}'), track: {why}",
                    feature.name
                ))
            })?;
            episodes.push(track);
        }
        // A placemark of several lines and tracks: its parts in order, `name-K`.
        if episodes.len() > 1 {
            for (k, episode) in episodes.iter_mut().enumerate() {
                episode.episode = format!("{}-{k}", feature.name);
            }
        }
        demonstrations.extend(episodes);
    }
    DrawnPaths::of_file(
        path,
        demonstrations,
        passed_over,
        KML_CRS.to_string(),
        "LineString or gx:Track in a Placemark",
    )
}

/// A `gx:Track` as an episode timed by its `<when>`s (by its positions' order where it
/// has none, or not one for each position).
fn timed_track(
    feature: &DrawnFeature,
    positions: &[[f64; 2]],
    whens: &[String],
    default_map: Option<&str>,
) -> std::result::Result<Demonstration, String> {
    let map = feature
        .map
        .clone()
        .or_else(|| default_map.map(String::from))
        .ok_or_else(|| {
            format!(
                "placemark {} names no map (an ExtendedData field 'map') and no default map \
                 is given (--default-map)",
                feature.index
            )
        })?;
    if positions.len() < 2 {
        return Err(format!("{} position(s); a path needs 2", positions.len()));
    }
    let fixes = positions
        .iter()
        .enumerate()
        .map(|(i, &[lon, lat])| {
            let time = match whens.get(i) {
                Some(when) if whens.len() == positions.len() => {
                    Some(parse_time(when).map_err(|why| format!("<when> {i} '{when}' {why}"))?)
                }
                _ => None,
            };
            Ok(Fix { lon, lat, time })
        })
        .collect::<std::result::Result<Vec<_>, String>>()?;
    Ok(Demonstration {
        episode: feature.name.clone(),
        map,
        poses: timed_poses(&fixes)?,
    })
}

/// The KML documents of a KMZ archive, `doc.kml` first, then the others in the
/// archive's order (GDAL's LIBKML driver writes a layer a document under `layers/`,
/// linked from `doc.kml`): with their names.
fn kmz_documents(bytes: &[u8]) -> std::result::Result<Vec<(String, Vec<u8>)>, String> {
    let mut archive = zip::ZipArchive::new(std::io::Cursor::new(bytes))
        .map_err(|e| format!("is not a readable KMZ (ZIP) archive: {e}"))?;
    let mut names: Vec<String> = archive
        .file_names()
        .map(|n| n.map(|n| n.into_owned()))
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(|e| format!("is not a readable KMZ (ZIP) archive: {e}"))?
        .into_iter()
        .filter(|n| n.to_ascii_lowercase().ends_with(".kml"))
        .collect();
    names.sort_by_key(|n| !n.eq_ignore_ascii_case("doc.kml"));
    if names.is_empty() {
        return Err("is a KMZ archive holding no .kml document".into());
    }
    names
        .into_iter()
        .map(|name| {
            let mut document = Vec::new();
            // A document of over a GiB is no drawing: a ZIP bomb is not unzipped whole.
            archive
                .by_name(&name)
                .map_err(|e| format!("its {name}: {e}"))?
                .take(1 << 30)
                .read_to_end(&mut document)
                .map_err(|e| format!("its {name} cannot be unzipped: {e}"))?;
            Ok((name, document))
        })
        .collect()
}

/// The placemarks of a KML document, in file order, or why it cannot be read.
fn parse_placemarks(text: &str) -> std::result::Result<Vec<Placemark>, String> {
    let mut reader = Reader::from_str(text);
    let mut stack: Vec<String> = Vec::new();
    let mut placemarks = Vec::new();
    let mut current: Option<Placemark> = None;
    // The `name` attribute of the `Data` or `SimpleData` element open, and the text
    // of the element open.
    let mut field: Option<String> = None;
    let mut text_here = String::new();
    let mut saw_kml = false;
    loop {
        let event = reader.read_event().map_err(|e| {
            format!(
                "is not well-formed XML at byte {}: {e}",
                reader.error_position()
            )
        })?;
        match event {
            Event::Start(tag) => {
                let local = String::from_utf8_lossy(tag.local_name().as_ref()).into_owned();
                saw_kml |= local == "kml";
                match local.as_str() {
                    "Placemark" => current = Some(Placemark::default()),
                    "Data" | "SimpleData" => {
                        field = tag
                            .try_get_attribute("name")
                            .ok()
                            .flatten()
                            .and_then(|a| a.unescape_value().ok())
                            .map(|v| v.into_owned());
                    }
                    "Track" => {
                        if let Some(p) = current.as_mut() {
                            p.tracks.push((Vec::new(), Vec::new()));
                        }
                    }
                    _ => {}
                }
                stack.push(local);
                text_here.clear();
            }
            Event::Empty(tag) => {
                saw_kml |= tag.local_name().as_ref() == b"kml";
            }
            Event::Text(t) => {
                let piece = t
                    .decode()
                    .map_err(|e| format!("holds text that is not UTF-8: {e}"))?;
                text_here.push_str(&piece);
            }
            // `&amp;` and `&#38;`: XML's own entities and characters by number.
            Event::GeneralRef(entity) => {
                let character = entity
                    .resolve_char_ref()
                    .map_err(|e| format!("holds a malformed character reference: {e}"))?;
                let name = entity
                    .decode()
                    .map_err(|e| format!("holds an entity that is not UTF-8: {e}"))?;
                let named = quick_xml::escape::resolve_predefined_entity(&name);
                match character.map(String::from).or(named.map(String::from)) {
                    Some(text) => text_here.push_str(&text),
                    None => return Err(format!("holds an unknown entity &{name};")),
                }
            }
            Event::CData(t) => text_here.push_str(&String::from_utf8_lossy(&t)),
            Event::End(_) => {
                let Some(local) = stack.pop() else {
                    return Err("closes an element it never opened".into());
                };
                let parent = stack.last().map(String::as_str);
                let text = text_here.trim().to_string();
                text_here.clear();
                match (local.as_str(), current.as_mut()) {
                    ("Placemark", _) => placemarks.extend(current.take()),
                    ("name", Some(p)) if parent == Some("Placemark") && !text.is_empty() => {
                        p.name = Some(text);
                    }
                    // An ExtendedData field `map`: `<Data name="map"><value>`, or
                    // `<SimpleData name="map">` of a schema.
                    ("value" | "SimpleData", Some(p))
                        if (local == "SimpleData" || parent == Some("Data"))
                            && field.as_deref() == Some("map")
                            && !text.is_empty() =>
                    {
                        p.map = Some(text);
                    }
                    ("coordinates", Some(p)) if parent == Some("LineString") => {
                        let line = coordinates(&text).map_err(|why| {
                            format!("placemark {}: <coordinates> {why}", placemarks.len())
                        })?;
                        p.lines.push(line);
                    }
                    ("coord", Some(p)) if parent == Some("Track") => {
                        let position = track_coord(&text).map_err(|why| {
                            format!("placemark {}: <gx:coord> {why}", placemarks.len())
                        })?;
                        if let Some(track) = p.tracks.last_mut() {
                            track.0.push(position);
                        }
                    }
                    ("when", Some(p)) if parent == Some("Track") => {
                        if let Some(track) = p.tracks.last_mut() {
                            track.1.push(text);
                        }
                    }
                    _ => {}
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if !saw_kml {
        return Err("is not KML: it has no <kml> element".into());
    }
    Ok(placemarks)
}

/// A `<coordinates>` list: `lon,lat[,alt]` tuples apart by white space.
fn coordinates(text: &str) -> std::result::Result<Vec<[f64; 2]>, String> {
    text.split_whitespace()
        .map(|tuple| {
            let mut parts = tuple.split(',').map(|v| v.trim().parse::<f64>());
            match (parts.next(), parts.next()) {
                (Some(Ok(lon)), Some(Ok(lat))) if lon.is_finite() && lat.is_finite() => {
                    Ok([lon, lat])
                }
                _ => Err(format!("'{tuple}' is not longitude,latitude")),
            }
        })
        .collect()
}

/// A `<gx:coord>`: `lon lat [alt]` apart by spaces.
fn track_coord(text: &str) -> std::result::Result<[f64; 2], String> {
    let mut parts = text.split_whitespace().map(str::parse::<f64>);
    match (parts.next(), parts.next()) {
        (Some(Ok(lon)), Some(Ok(lat))) if lon.is_finite() && lat.is_finite() => Ok([lon, lat]),
        _ => Err(format!("'{text}' is not longitude latitude")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DRAWN: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<kml xmlns="http://www.opengis.net/kml/2.2" xmlns:gx="http://www.google.com/kml/ext/2.2">
<Document><name>routes</name>
  <Placemark><name>ridge &amp; saddle</name>
    <ExtendedData><Data name="map"><value>site</value></Data></ExtendedData>
    <LineString><tessellate>1</tessellate>
      <coordinates>7.25,46.5,1500 7.2501,46.5001,1501
        7.2502,46.5002</coordinates></LineString></Placemark>
  <Placemark><name>camp</name><Point><coordinates>7,46</coordinates></Point></Placemark>
  <Placemark><MultiGeometry>
    <LineString><coordinates>1,2 3,4</coordinates></LineString>
    <LineString><coordinates>5,6 7,8</coordinates></LineString>
  </MultiGeometry></Placemark>
  <Placemark><name>walk</name><gx:Track>
    <when>2024-05-01T10:00:00Z</when><when>2024-05-01T10:00:04Z</when>
    <gx:coord>7.3 46.6 1400</gx:coord><gx:coord>7.3001 46.6001 1401</gx:coord>
  </gx:Track></Placemark>
</Document></kml>"#;

    #[test]
    fn lines_and_tracks_of_placemarks_become_episodes() {
        let placemarks = parse_placemarks(DRAWN).unwrap();
        assert_eq!(placemarks.len(), 4);
        assert_eq!(placemarks[0].name.as_deref(), Some("ridge & saddle"));
        assert_eq!(placemarks[0].map.as_deref(), Some("site"));
        assert_eq!(placemarks[0].lines[0].len(), 3);
        assert!(placemarks[1].lines.is_empty());
        assert_eq!(placemarks[2].lines.len(), 2);
        assert_eq!(placemarks[3].tracks[0].0, [[7.3, 46.6], [7.3001, 46.6001]]);
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("drawn.kml");
        std::fs::write(&file, DRAWN).unwrap();
        let paths = read_kml_paths(&file, Some("terrain")).unwrap();
        let episodes: Vec<(&str, &str, usize)> = paths
            .demonstrations
            .iter()
            .map(|d| (d.episode.as_str(), d.map.as_str(), d.poses.len()))
            .collect();
        assert_eq!(
            episodes,
            [
                ("ridge & saddle", "site", 3),
                ("drawn-002-0", "terrain", 2),
                ("drawn-002-1", "terrain", 2),
                ("walk", "terrain", 2),
            ]
        );
        let walk = &paths.demonstrations[3].poses;
        assert_eq!((walk[0].t, walk[1].t), (0.0, 4.0));
        assert_eq!(paths.crs, "EPSG:4326");
    }

    #[test]
    fn a_kmz_is_read_through_its_document() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("drawn.kmz");
        let mut archive = zip::ZipWriter::new(std::fs::File::create(&file).unwrap());
        archive
            .start_file("doc.kml", zip::write::SimpleFileOptions::default())
            .unwrap();
        std::io::Write::write_all(&mut archive, DRAWN.as_bytes()).unwrap();
        archive.finish().unwrap();
        let paths = read_kml_paths(&file, Some("terrain")).unwrap();
        assert_eq!(paths.demonstrations.len(), 4);
    }

    #[test]
    fn malformed_kml_says_why() {
        let error = |text: &str| parse_placemarks(text).err().unwrap();
        assert!(error("<gpx></gpx>").contains("not KML"));
        assert!(
            error("<kml><Placemark><LineString><coordinates>1,2 x,y</coordinates></LineString></Placemark></kml>")
                .contains("'x,y'")
        );
        assert!(error("<kml><Placemark></kml>").contains("XML"));
    }

    proptest::proptest! {
        /// Any text reads or is refused with an error: never a panic.
        #[test]
        fn any_text_reads_or_is_refused(text in "\\PC{0,300}") {
            let _ = parse_placemarks(&text);
            let _ = parse_placemarks(&format!("<kml><Placemark>{text}</Placemark></kml>"));
        }
    }
}
