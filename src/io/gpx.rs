//! GPS tracks as GPX files (GPX 1.0 and 1.1: what handheld GPS units, phones, Garmin
//! Connect, Strava and QGIS export). Every track segment (`<trk><trkseg>`) is one
//! episode of WGS84 longitude and latitude (x and y), timed by its points' `<time>`.
//! Everything else (waypoints, routes, elevations, extensions of any vendor) is passed
//! over: a route is a plan someone drew, not a path someone took.

use std::path::Path;

use quick_xml::events::{BytesStart, Event};
use quick_xml::reader::Reader;
use time::OffsetDateTime;
use time::format_description::well_known::Iso8601;

use crate::error::{Error, Result, read_input};
use crate::grid::{Demonstration, Pose};

/// The CRS of every GPX file's coordinates (the GPX schema fixes WGS84).
pub const GPX_CRS: &str = "EPSG:4326";

/// One `<trkpt>` (or a KML track's position): where, and when if the file says.
pub(super) struct Fix {
    pub lon: f64,
    pub lat: f64,
    pub time: Option<f64>,
}

/// The segments of each track of a GPX document, in file order.
type Tracks = Vec<Vec<Vec<Fix>>>;

/// The episodes of the GPX file at `path`, on map `map`: `<stem>-track-NNN` for a track
/// of one segment, `<stem>-track-NNN-MMM` for the segments of a track of several.
/// Segments of fewer than two points are left out with a warning.
pub fn read_gpx(path: &Path, map: &str) -> Result<Vec<Demonstration>> {
    let bytes = read_input(path)?;
    let text = std::str::from_utf8(&bytes)
        .map_err(|e| Error::input(path, format!("is not UTF-8 text (GPX is XML): {e}")))?;
    let tracks = parse_tracks(text).map_err(|why| Error::input(path, why))?;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut demos = Vec::new();
    for (t, segments) in tracks.iter().enumerate() {
        for (s, fixes) in segments.iter().enumerate() {
            let episode = if segments.len() == 1 {
                format!("{stem}-track-{t:03}")
            } else {
                format!("{stem}-track-{t:03}-{s:03}")
            };
            if fixes.len() < 2 {
                tracing::warn!(
                    "{}: track {t} segment {s} has {} point(s); left out (an episode needs 2)",
                    path.display(),
                    fixes.len()
                );
                continue;
            }
            let poses = timed_poses(fixes)
                .map_err(|why| Error::input(path, format!("track {t} segment {s}: {why}")))?;
            demos.push(Demonstration {
                episode,
                map: map.to_string(),
                poses,
            });
        }
    }
    if demos.is_empty() {
        return Err(Error::input(
            path,
            "holds no track segment of two points or more (<trk><trkseg><trkpt>; routes and \
             waypoints are not tracks)",
        ));
    }
    Ok(demos)
}

/// A segment's fixes as poses (x the longitude, y the latitude), timed as
/// [`segment_times`] times them.
pub(super) fn timed_poses(fixes: &[Fix]) -> std::result::Result<Vec<Pose>, String> {
    let times = segment_times(fixes)?;
    Ok(fixes
        .iter()
        .zip(times)
        .map(|(fix, t)| Pose {
            t,
            x: fix.lon,
            y: fix.lat,
            yaw: None,
        })
        .collect())
}

/// Seconds from a segment's first point: its times where every point has one, else the
/// points' order (a track drawn by hand has no times; a warning says so when only some
/// points lack theirs). Points logged within one second (a 1 Hz logger's repeated
/// stamp) are spread evenly to the next stamp; a time that goes back is an error.
fn segment_times(fixes: &[Fix]) -> std::result::Result<Vec<f64>, String> {
    let stamped: Option<Vec<f64>> = fixes.iter().map(|f| f.time).collect();
    let Some(stamps) = stamped else {
        if fixes.iter().any(|f| f.time.is_some()) {
            tracing::warn!("some points of a GPX segment have no <time>: timed by their order");
        }
        return Ok((0..fixes.len()).map(|i| i as f64).collect());
    };
    if let Some(i) = (1..stamps.len()).find(|&i| stamps[i] < stamps[i - 1]) {
        return Err(format!(
            "point {i}'s time is {} s before point {}'s: points must be in time order",
            stamps[i - 1] - stamps[i],
            i - 1
        ));
    }
    let first = stamps[0];
    let mut times = Vec::with_capacity(stamps.len());
    let mut i = 0;
    while i < stamps.len() {
        let run = stamps[i..].iter().take_while(|&&s| s == stamps[i]).count();
        let next = stamps.get(i + run).copied().unwrap_or(stamps[i] + 1.0);
        for k in 0..run {
            times.push(stamps[i] - first + (next - stamps[i]) * k as f64 / run as f64);
        }
        i += run;
    }
    Ok(times)
}

/// The tracks' points of a GPX document, or why it cannot be read.
fn parse_tracks(text: &str) -> std::result::Result<Tracks, String> {
    let mut reader = Reader::from_str(text);
    let at = |reader: &Reader<&[u8]>| reader.buffer_position();
    let malformed = |position: u64, e: &dyn std::fmt::Display| {
        format!("is not well-formed XML at byte {position}: {e}")
    };
    let mut tracks: Tracks = Vec::new();
    let mut root_seen = false;
    // Where the reader is: inside <trk>, <trkseg>, the open <trkpt>, its <time>.
    let (mut in_track, mut in_segment, mut in_time) = (false, false, false);
    let mut open_fix: Option<Fix> = None;
    let mut time_text = String::new();
    loop {
        let event = reader
            .read_event()
            .map_err(|e| malformed(at(&reader), &e))?;
        match event {
            Event::Eof => break,
            Event::Start(tag) | Event::Empty(tag) if !root_seen => {
                if tag.local_name().as_ref() != b"gpx" {
                    return Err(format!(
                        "is not GPX: its root element is <{}>, not <gpx>",
                        String::from_utf8_lossy(tag.name().as_ref())
                    ));
                }
                root_seen = true;
            }
            Event::Start(ref tag) | Event::Empty(ref tag) => {
                let empty = matches!(event, Event::Empty(_));
                match tag.local_name().as_ref() {
                    b"trk" if !empty => {
                        in_track = true;
                        tracks.push(Vec::new());
                    }
                    b"trkseg" if in_track => {
                        tracks.last_mut().expect("inside a track").push(Vec::new());
                        in_segment = !empty;
                    }
                    b"trkpt" if in_segment => {
                        let (t, s) = position(&tracks);
                        let fix = read_fix(tag).map_err(|why| {
                            format!("track {t} segment {s} point {}: {why}", tracks[t][s].len())
                        })?;
                        if empty {
                            push_fix(&mut tracks, fix);
                        } else {
                            open_fix = Some(fix);
                        }
                    }
                    b"time" if open_fix.is_some() && !empty => {
                        in_time = true;
                        time_text.clear();
                    }
                    _ => {}
                }
            }
            Event::Text(text) if in_time => {
                let text = text.decode().map_err(|e| malformed(at(&reader), &e))?;
                time_text.push_str(&text);
            }
            Event::End(tag) => match tag.local_name().as_ref() {
                b"time" if in_time => {
                    in_time = false;
                    let (t, s) = position(&tracks);
                    let seconds = parse_time(time_text.trim()).map_err(|why| {
                        format!(
                            "track {t} segment {s} point {}: <time>{}</time> {why}",
                            tracks[t][s].len(),
                            time_text.trim()
                        )
                    })?;
                    if let Some(fix) = &mut open_fix {
                        fix.time = Some(seconds);
                    }
                }
                b"trkpt" => {
                    if let Some(fix) = open_fix.take() {
                        push_fix(&mut tracks, fix);
                    }
                }
                b"trkseg" => in_segment = false,
                b"trk" => in_track = false,
                _ => {}
            },
            _ => {}
        }
    }
    if !root_seen {
        return Err("is not GPX: it holds no <gpx> element".into());
    }
    Ok(tracks)
}

/// The track and segment being read.
fn position(tracks: &Tracks) -> (usize, usize) {
    let t = tracks.len() - 1;
    (t, tracks[t].len() - 1)
}

fn push_fix(tracks: &mut Tracks, fix: Fix) {
    let (t, s) = position(tracks);
    tracks[t][s].push(fix);
}

/// A `<trkpt>`'s `lat` and `lon`, which GPX requires.
fn read_fix(tag: &BytesStart) -> std::result::Result<Fix, String> {
    let (mut lat, mut lon) = (None, None);
    for attribute in tag.attributes() {
        let attribute = attribute.map_err(|e| format!("a malformed attribute: {e}"))?;
        let value = attribute
            .unescape_value()
            .map_err(|e| format!("a malformed attribute: {e}"))?;
        let number = || -> std::result::Result<f64, String> {
            value
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("'{value}' is not a number of degrees"))
        };
        match attribute.key.local_name().as_ref() {
            b"lat" => lat = Some(number()?),
            b"lon" => lon = Some(number()?),
            _ => {}
        }
    }
    match (lat, lon) {
        (Some(lat), Some(lon)) if lat.abs() <= 90.0 && lon.abs() <= 180.0 => Ok(Fix {
            lon,
            lat,
            time: None,
        }),
        (Some(lat), Some(lon)) => Err(format!(
            "lat {lat}, lon {lon} is not on the Earth (lat within ±90°, lon within ±180°)"
        )),
        _ => Err("has no lat and lon attributes".into()),
    }
}

/// Seconds since the Unix epoch of an xsd:dateTime (`2024-05-01T10:00:00Z`, with
/// fractions or an offset; without an offset, UTC, as GPX says its times are).
pub(super) fn parse_time(text: &str) -> std::result::Result<f64, String> {
    let parsed = OffsetDateTime::parse(text, &Iso8601::PARSING).or_else(|_| {
        time::PrimitiveDateTime::parse(text, &Iso8601::PARSING).map(|t| t.assume_utc())
    });
    let time = parsed.map_err(|e| format!("is not a date and time: {e}"))?;
    Ok(time.unix_timestamp_nanos() as f64 * 1e-9)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRACK: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<gpx version="1.1" creator="test" xmlns="http://www.topografix.com/GPX/1/1"
     xmlns:gpxtpx="http://www.garmin.com/xmlschemas/TrackPointExtension/v1">
  <wpt lat="1" lon="1"><name>camp</name></wpt>
  <rte><rtept lat="2" lon="2"/></rte>
  <trk><name>morning</name>
    <trkseg>
      <trkpt lat="46.5" lon="7.25"><ele>1500</ele><time>2024-05-01T10:00:00Z</time>
        <extensions><gpxtpx:TrackPointExtension><gpxtpx:hr>120</gpxtpx:hr></gpxtpx:TrackPointExtension></extensions>
      </trkpt>
      <trkpt lat="46.5001" lon="7.2501"><time>2024-05-01T12:00:01+02:00</time></trkpt>
      <trkpt lat="46.5002" lon="7.2502"><time>2024-05-01T10:00:01Z</time></trkpt>
      <trkpt lat="46.5003" lon="7.2503"><time>2024-05-01T10:00:02.5Z</time></trkpt>
    </trkseg>
  </trk>
  <trk><trkseg><trkpt lat="-10" lon="-20"/><trkpt lat="-10.1" lon="-20"/></trkseg>
       <trkseg><trkpt lat="0" lon="0"/></trkseg></trk>
</gpx>"#;

    #[test]
    fn tracks_segments_and_times_become_episodes() {
        let tracks = parse_tracks(TRACK).unwrap();
        assert_eq!(tracks.len(), 2);
        assert_eq!((tracks[0].len(), tracks[0][0].len()), (1, 4));
        assert_eq!(
            (tracks[1].len(), tracks[1][0].len(), tracks[1][1].len()),
            (2, 2, 1)
        );
        let first = &tracks[0][0];
        assert_eq!((first[0].lon, first[0].lat), (7.25, 46.5));
        // Two stamps of one second (one with an offset) spread over it; a fraction kept.
        assert_eq!(segment_times(first).unwrap(), vec![0.0, 1.0, 1.75, 2.5]);
        // No times: the points' order.
        assert_eq!(segment_times(&tracks[1][0]).unwrap(), vec![0.0, 1.0]);
    }

    #[test]
    fn a_file_becomes_named_episodes_and_drops_single_points() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("hike.gpx");
        std::fs::write(&path, TRACK).unwrap();
        let demos = read_gpx(&path, "dem").unwrap();
        let names: Vec<&str> = demos.iter().map(|d| d.episode.as_str()).collect();
        assert_eq!(names, ["hike-track-000", "hike-track-001-000"]);
        assert!(demos.iter().all(|d| d.map == "dem"));
        assert_eq!(demos[1].poses[1].y, -10.1);
    }

    #[test]
    fn what_cannot_be_read_is_named() {
        for (text, says) in [
            ("<kml/>", "root element is <kml>"),
            ("", "holds no <gpx> element"),
            (
                "<gpx><trk><trkseg><trkpt lat='x' lon='1'/></trkseg></trk></gpx>",
                "track 0 segment 0 point 0: 'x' is not a number",
            ),
            (
                "<gpx><trk><trkseg><trkpt lat='1'/></trkseg></trk></gpx>",
                "has no lat and lon",
            ),
            (
                "<gpx><trk><trkseg><trkpt lat='91' lon='1'/></trkseg></trk></gpx>",
                "not on the Earth",
            ),
            (
                "<gpx><trk><trkseg><trkpt lat='1' lon='1'><time>noon</time></trkpt></trkseg></trk></gpx>",
                "<time>noon</time> is not a date",
            ),
            ("<gpx><trk><trkseg></gpx>", "not well-formed"),
        ] {
            let why = parse_tracks(text).err().unwrap_or_default();
            assert!(why.contains(says), "{text}: {why}");
        }
        let backwards = [0.0, 5.0, 4.0].map(|t| Fix {
            lon: 0.0,
            lat: 0.0,
            time: Some(t),
        });
        let why = segment_times(&backwards).unwrap_err();
        assert!(
            why.contains("point 2's time is 1 s before point 1's"),
            "{why}"
        );
    }
}
