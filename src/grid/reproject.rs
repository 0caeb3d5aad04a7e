//! Points given in another CRS than their map's, as GPS tracks come (longitude and
//! latitude on a UTM raster), moved into the map's frame. The transformation is
//! `proj4rs`'s (a pure-Rust port of PROJ.4's, datum shifts by the registry's `towgs84`
//! terms); the CRSs are the EPSG registry's PROJ strings (`crs-definitions`), the map's
//! in the units its frame keeps.

use proj4rs::proj::Proj;

use super::GeoRef;
use super::epsg::metres_per_epsg_unit;

/// GeoTIFF's ProjLinearUnits key.
const PROJ_LINEAR_UNITS: u16 = 3076;

/// A CRS as PROJ takes it, with whether its coordinates are degrees (PROJ's are radians).
struct Crs {
    proj: Proj,
    degrees: bool,
}

impl Crs {
    fn from_proj_string(definition: &str) -> Result<Crs, String> {
        let proj = Proj::from_proj_string(definition).map_err(|e| e.to_string())?;
        Ok(Crs {
            degrees: proj.is_latlong(),
            proj,
        })
    }
}

/// The registry's PROJ string of `EPSG:<code>`.
fn epsg_definition(code: &str) -> Result<&'static str, String> {
    let number: u16 = code
        .trim()
        .parse()
        .map_err(|_| format!("'EPSG:{code}' is not an EPSG code"))?;
    crs_definitions::from_code(number)
        .map(|d| d.proj4)
        .ok_or_else(|| format!("EPSG:{number} is not in the EPSG registry's copy here"))
}

/// A CRS the user names: `EPSG:<code>` or a PROJ string (`+proj=...`).
fn parse_user_crs(spec: &str) -> Result<Crs, String> {
    let spec = spec.trim();
    let definition = match spec.split_once(':') {
        Some((authority, code)) if authority.eq_ignore_ascii_case("EPSG") => {
            epsg_definition(code)?.to_string()
        }
        _ if spec.starts_with('+') => spec.to_string(),
        _ => {
            return Err(format!(
                "'{spec}' is not a CRS: name it as EPSG:<code> (EPSG:4326 for GPS \
                 longitude and latitude) or give a PROJ string (+proj=...)"
            ));
        }
    };
    Crs::from_proj_string(&definition).map_err(|why| format!("the CRS '{spec}': {why}"))
}

/// The CRS of a map's frame: its EPSG code, in the linear unit its GeoTIFF's keys
/// gave where that is not the code's own (the frame keeps the TIFF's coordinates).
fn map_crs(geo: &GeoRef) -> Result<Crs, String> {
    let keyed = geo.tiff_crs.as_ref().and_then(|crs| crs.proj.as_deref());
    if let (None, Some(definition)) = (geo.frame.strip_prefix("EPSG:"), keyed) {
        return Crs::from_proj_string(definition)
            .map_err(|why| format!("its CRS '{definition}': {why}"));
    }
    let code = geo.frame.strip_prefix("EPSG:").ok_or_else(|| {
        format!(
            "its frame '{}' names no EPSG code, nor do its GeoTIFF keys define a \
             projection PROJ knows, so nothing in another CRS can be moved into it or \
             out of it",
            geo.frame
        )
    })?;
    let mut definition = epsg_definition(code)?.to_string();
    let keyed_unit = keyed_linear_unit(geo).and_then(metres_per_epsg_unit);
    if let Some(metres) = keyed_unit.filter(|_| !geo.degrees) {
        definition = definition
            .split_whitespace()
            .filter(|term| !term.starts_with("+units=") && !term.starts_with("+to_meter="))
            .chain([format!("+to_meter={metres}").as_str()])
            .collect::<Vec<_>>()
            .join(" ");
    }
    Crs::from_proj_string(&definition).map_err(|why| format!("its CRS EPSG:{code}: {why}"))
}

/// Whether two maps' frames are one CRS in one unit, so that their coordinates need
/// no transformation between them.
pub fn same_crs(a: &GeoRef, b: &GeoRef) -> bool {
    a.frame == b.frame && a.degrees == b.degrees && keyed_linear_unit(a) == keyed_linear_unit(b)
}

/// The linear unit a map's GeoTIFF keys give (ProjLinearUnits), if they give one.
fn keyed_linear_unit(geo: &GeoRef) -> Option<u16> {
    geo.tiff_crs.as_ref().and_then(|crs| {
        crs.keys
            .iter()
            .find(|k| k[0] == PROJ_LINEAR_UNITS && k[1] == 0)
            .map(|k| k[3])
    })
}

/// Moves points from one CRS into one map's frame.
pub struct Reprojection {
    source: Crs,
    target: Crs,
}

impl Reprojection {
    /// From `source` (`EPSG:<code>` or a PROJ string) into the frame of `geo`, which
    /// must name its EPSG code (GeoTIFF maps do). The error says which side is wrong.
    pub fn new(source: &str, geo: &GeoRef) -> Result<Reprojection, String> {
        Ok(Reprojection {
            source: parse_user_crs(source)?,
            target: map_crs(geo).map_err(|why| format!("the map's CRS: {why}"))?,
        })
    }

    /// From the frame of `geo` into `target` (`EPSG:<code>` or a PROJ string): the
    /// inverse of [`Reprojection::new`], to answer in the CRS a user asked in.
    pub fn out_of(geo: &GeoRef, target: &str) -> Result<Reprojection, String> {
        Ok(Reprojection {
            source: map_crs(geo).map_err(|why| format!("the map's CRS: {why}"))?,
            target: parse_user_crs(target)?,
        })
    }

    /// From the frame of one map into another's; both must name their EPSG code.
    pub fn between(source: &GeoRef, target: &GeoRef) -> Result<Reprojection, String> {
        Ok(Reprojection {
            source: map_crs(source)?,
            target: map_crs(target)?,
        })
    }

    /// The point (`x`, `y`) of the source CRS (degrees where it is geographic) in the
    /// map's frame; an error where it lies outside what the projections can carry.
    pub fn point(&self, x: f64, y: f64) -> Result<(f64, f64), String> {
        let radians = |v: f64, degrees| if degrees { v.to_radians() } else { v };
        let mut point = (
            radians(x, self.source.degrees),
            radians(y, self.source.degrees),
            0.0,
        );
        proj4rs::transform::transform(&self.source.proj, &self.target.proj, &mut point)
            .map_err(|e| e.to_string())?;
        let (mut tx, mut ty) = (point.0, point.1);
        if self.target.degrees {
            (tx, ty) = (tx.to_degrees(), ty.to_degrees());
        }
        if tx.is_finite() && ty.is_finite() {
            Ok((tx, ty))
        } else {
            Err("it lies outside what the projections can carry".into())
        }
    }

    /// A heading (radians counter-clockwise from +x of the source CRS) at (`x`, `y`),
    /// as the direction of a short step along it in the map's frame: grid convergence
    /// turns headings between a geographic and a projected CRS, or two projections.
    pub fn heading(&self, x: f64, y: f64, yaw: f64) -> Result<f64, String> {
        let step = if self.source.degrees { 1e-6 } else { 1e-2 };
        let (x0, y0) = self.point(x, y)?;
        let (x1, y1) = self.point(x + step * yaw.cos(), y + step * yaw.sin())?;
        Ok((y1 - y0).atan2(x1 - x0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(code: &str, degrees: bool) -> GeoRef {
        GeoRef {
            frame: code.into(),
            degrees,
            ..GeoRef::unit(10, 10)
        }
    }

    fn close(a: (f64, f64), b: (f64, f64), tolerance: f64) -> bool {
        (a.0 - b.0).abs() < tolerance && (a.1 - b.1).abs() < tolerance
    }

    // Expected coordinates are PROJ 9's (rasterio.warp.transform, GDAL 3.9).
    #[test]
    fn longitude_and_latitude_go_to_utm_web_mercator_and_state_plane_feet_as_proj_puts_them() {
        let utm = Reprojection::new("EPSG:4326", &frame("EPSG:32621", false)).unwrap();
        let p = utm.point(-54.716901362097154, -25.443786452863478).unwrap();
        assert!(close(p, (729591.0, -2816055.0), 1e-3), "{p:?}");
        let mercator = Reprojection::new("epsg:4326", &frame("EPSG:3857", false)).unwrap();
        let p = mercator.point(-122.4, 37.8).unwrap();
        assert!(
            close(p, (-13625505.673096687, 4551210.91969189), 1e-3),
            "{p:?}"
        );
        // EPSG:2263 is in US survey feet, and so is a frame read from its code.
        let feet = Reprojection::new("EPSG:4326", &frame("EPSG:2263", false)).unwrap();
        let p = feet.point(-73.98, 40.75).unwrap();
        assert!(
            close(p, (989791.457348593, 212522.5192392543), 1e-3),
            "{p:?}"
        );
        // A datum shift: the British National Grid on OSGB36 (PROJ's towgs84, 3 mm).
        let british = Reprojection::new("EPSG:4326", &frame("EPSG:27700", false)).unwrap();
        let p = british.point(-1.5, 52.0).unwrap();
        assert!(close(p, (434423.007, 233624.375), 0.01), "{p:?}");
    }

    #[test]
    fn a_frame_whose_keys_give_metres_for_a_code_in_feet_takes_metres() {
        let mut geo = frame("EPSG:2263", false);
        geo.tiff_crs = Some(crate::grid::TiffCrs {
            keys: vec![[3072, 0, 1, 2263], [PROJ_LINEAR_UNITS, 0, 1, 9001]],
            doubles: Vec::new(),
            ascii: String::new(),
            frame_units_per_unit: 1.0,
            proj: None,
        });
        let metres = Reprojection::new("EPSG:4326", &geo).unwrap();
        let p = metres.point(-73.98, 40.75).unwrap();
        let us_foot = 1200.0 / 3937.0;
        assert!(
            close(
                p,
                (989791.457348593 * us_foot, 212522.5192392543 * us_foot),
                1e-3
            ),
            "{p:?}"
        );
    }

    #[test]
    fn projected_points_go_back_to_degrees_and_round_trip() {
        let to_degrees = Reprojection::new("EPSG:32621", &frame("EPSG:4326", true)).unwrap();
        let (lon, lat) = to_degrees.point(729591.0, -2816055.0).unwrap();
        assert!(
            close((lon, lat), (-54.716901362097154, -25.443786452863478), 1e-8),
            "{lon} {lat}"
        );
        let proj_string = "+proj=utm +zone=21 +south +datum=WGS84 +units=m +no_defs";
        let from_string = Reprojection::new(proj_string, &frame("EPSG:4326", true)).unwrap();
        let (lon2, _) = from_string.point(729591.0, 7183945.0).unwrap();
        assert!((lon2 - lon).abs() < 1e-8, "{lon2} {lon}");
    }

    #[test]
    fn points_of_a_frame_in_feet_go_out_to_longitude_and_latitude_and_back() {
        let feet = frame("EPSG:2263", false);
        let out = Reprojection::out_of(&feet, "EPSG:4326").unwrap();
        let (lon, lat) = out.point(989791.457348593, 212522.5192392543).unwrap();
        assert!(close((lon, lat), (-73.98, 40.75), 1e-9), "{lon} {lat}");
        let back = Reprojection::new("EPSG:4326", &feet).unwrap();
        let p = back.point(lon, lat).unwrap();
        assert!(
            close(p, (989791.457348593, 212522.5192392543), 1e-6),
            "{p:?}"
        );
        let why = Reprojection::out_of(&GeoRef::unit(4, 4), "EPSG:4326")
            .err()
            .unwrap();
        assert!(why.contains("the map's CRS"), "{why}");
    }

    #[test]
    fn headings_turn_by_the_grid_convergence() {
        // 3° east of UTM 21S's central meridian (57° W) at 25° S, true north points
        // about 1.27° west of grid north (sin 25° × tan 3°, in radians).
        let utm = Reprojection::new("EPSG:4326", &frame("EPSG:32721", false)).unwrap();
        let north = utm
            .heading(-54.0, -25.0, std::f64::consts::FRAC_PI_2)
            .unwrap();
        let convergence = (25f64.to_radians().sin() * 3f64.to_radians().tan()).atan();
        assert!(
            (north - (std::f64::consts::FRAC_PI_2 - convergence)).abs() < 1e-3,
            "{}",
            north.to_degrees()
        );
    }

    #[test]
    fn crss_that_cannot_be_named_or_used_are_explained() {
        let map = frame("EPSG:32621", false);
        for (spec, says) in [
            ("WGS84", "is not a CRS"),
            ("EPSG:abc", "is not an EPSG code"),
            ("EPSG:1", "not in the EPSG registry"),
            ("+proj=nonsense", "the CRS '+proj=nonsense'"),
        ] {
            let why = Reprojection::new(spec, &map).err().unwrap();
            assert!(why.contains(says), "{spec}: {why}");
        }
        let why = Reprojection::new("EPSG:4326", &GeoRef::unit(4, 4))
            .err()
            .unwrap();
        assert!(why.contains("names no EPSG code"), "{why}");
    }
}
