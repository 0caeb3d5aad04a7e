//! EPSG's CRSs by code, from the EPSG registry's PROJ strings (the `crs-definitions`
//! crate): a projected CRS's linear unit, for GeoTIFFs that name their CRS by its code
//! alone (no ProjLinearUnits key: GDAL then looks the code up, and a State Plane grid in
//! US survey feet is read in feet), and its projection's parameters, so that a projection
//! the reader measures is known for every code the registry holds, not only those
//! `Projection::of_epsg` lists by hand.

use super::equal_area::{Ellipsoid, EqualArea};
use super::geodesy::{PolarScale, Projection};

/// A CRS as a PROJ string's `+key=value` terms: one of the registry's, or one a file
/// gives (R's raster headers write their CRS so).
pub struct ProjCrs {
    terms: Vec<(String, String)>,
}

/// The registry's CRS of `code`; `None` for codes it does not hold (vertical CRSs,
/// codes newer than it).
pub fn epsg_crs(code: u16) -> Option<ProjCrs> {
    crs_definitions::from_code(code).map(|definition| ProjCrs::parse(definition.proj4))
}

/// Metres per linear unit, for the EPSG unit codes rasters use (GeoTIFF's
/// ProjLinearUnits and VerticalUnits keys).
pub fn metres_per_epsg_unit(code: u16) -> Option<f64> {
    match code {
        9001 => Some(1.0),             // metre
        9002 => Some(0.3048),          // international foot
        9003 => Some(1200.0 / 3937.0), // US survey foot
        9036 => Some(1000.0),          // kilometre
        _ => None,
    }
}

/// Metres per unit of PROJ's named linear units (`+units=`).
fn metres_per_named_unit(name: &str) -> Option<f64> {
    Some(match name {
        "m" => 1.0,
        "km" => 1000.0,
        "dm" => 0.1,
        "cm" => 0.01,
        "ft" => 0.3048,
        "us-ft" => 1200.0 / 3937.0,
        "yd" => 0.9144,
        "us-yd" => 3600.0 / 3937.0,
        "ch" => 20.1168,
        "us-ch" => 79200.0 / 3937.0,
        "link" => 0.201168,
        "us-mi" => 6_336_000.0 / 3937.0,
        "mi" => 1609.344,
        _ => return None,
    })
}

impl ProjCrs {
    /// The terms of PROJ string `proj` (`+proj=utm +zone=33 +south`: flags have no value).
    pub fn parse(proj: &str) -> ProjCrs {
        let terms = proj
            .split_whitespace()
            .filter_map(|term| term.strip_prefix('+'))
            .map(|term| term.split_once('=').unwrap_or((term, "")))
            .map(|(key, value)| (key.to_string(), value.to_string()))
            .collect();
        ProjCrs { terms }
    }

    /// The value of term `key` (empty for a flag).
    pub fn value(&self, key: &str) -> Option<&str> {
        self.terms
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The value of term `key`, where it is a finite number.
    pub fn number(&self, key: &str) -> Option<f64> {
        self.value(key)?
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
    }

    /// Whether term `key` is given (`+south`).
    pub fn has(&self, key: &str) -> bool {
        self.terms.iter().any(|(k, _)| k == key)
    }

    /// PROJ's projection name (`tmerc`, `lcc`, `longlat`, ...).
    pub fn projection_name(&self) -> &str {
        self.value("proj").unwrap_or("")
    }

    /// Latitude and longitude, in degrees.
    pub fn is_geographic(&self) -> bool {
        matches!(self.projection_name(), "longlat" | "latlong")
    }

    /// Metres per unit of a projected CRS's coordinates (`+to_meter`, else `+units`,
    /// else metres as PROJ defaults); `None` for geographic and geocentric CRSs and
    /// units PROJ names that are not lengths we know.
    pub fn metres_per_unit(&self) -> Option<f64> {
        if self.is_geographic() || self.projection_name() == "geocent" {
            return None;
        }
        match (self.number("to_meter"), self.value("units")) {
            (Some(factor), _) => Some(factor).filter(|f| *f > 0.0),
            (None, Some(name)) => metres_per_named_unit(name),
            (None, None) => Some(1.0),
        }
    }

    /// The ellipsoid of [`ProjCrs::axes`] (its eccentricity from `+b` where given).
    pub(crate) fn ellipsoid(&self) -> Ellipsoid {
        let given = (self.number("a"), self.number("rf"), self.number("b"));
        if let (Some(a), None, Some(b)) = given
            && a > 0.0
            && b > 0.0
            && b <= a
        {
            return Ellipsoid {
                a,
                e2: 1.0 - (b / a).powi(2),
            };
        }
        let (a, rf) = self.axes();
        Ellipsoid::from_inverse_flattening(a, rf)
    }

    /// The ellipsoid's semi-major axis and inverse flattening (0: a sphere): `+a` with
    /// `+rf` or `+b`, `+R`, else the named one or the datum's, else WGS 84's.
    pub fn axes(&self) -> (f64, f64) {
        if let Some(a) = self.number("a").filter(|a| *a > 0.0) {
            return match (self.number("rf"), self.number("b")) {
                (Some(rf), _) => (a, rf),
                (None, Some(b)) if b > 0.0 && b < a => (a, a / (a - b)),
                _ => (a, 0.0),
            };
        }
        if let Some(radius) = self.number("R").filter(|r| *r > 0.0) {
            return (radius, 0.0);
        }
        let name = match self.value("datum") {
            Some("NAD27") => "clrk66",
            Some("OSGB36") => "airy",
            Some("potsdam" | "hermannskogel") => "bessel",
            Some("nzgd49") => "intl",
            Some("ire65") => "mod_airy",
            Some("carthage") => "clrk80ign",
            _ => self.value("ellps").unwrap_or("WGS84"),
        };
        named_ellipsoid_axes(name)
    }

    /// The projection, where it is one whose scale the reader measures: Transverse
    /// Mercator and UTM, Lambert conformal conic, polar stereographic, Mercator on the
    /// ellipsoid, and the equal-area ones (Albers, Lambert azimuthal, cylindrical,
    /// sinusoidal, Equal Earth). False eastings and northings are PROJ's, in metres.
    pub fn projection(&self) -> Option<Projection> {
        let degrees = |key| self.number(key);
        let or_zero = |key| self.number(key).unwrap_or(0.0);
        let false_origin = [or_zero("x_0"), or_zero("y_0")];
        let scale = self.number("k").or(self.number("k_0")).unwrap_or(1.0);
        let ellipsoid = self.ellipsoid();
        let equal_area = match self.projection_name() {
            "utm" => return Some(Projection::transverse_mercator(0.9996, 500_000.0)),
            "tmerc" => return Some(Projection::transverse_mercator(scale, false_origin[0])),
            "lcc" => {
                let first = degrees("lat_1")?;
                let second = degrees("lat_2").unwrap_or(first);
                let origin = degrees("lat_0").unwrap_or(first);
                return Some(Projection::lambert_conformal(
                    [first, second],
                    scale,
                    origin,
                    false_origin,
                ));
            }
            "stere" => {
                // Polar only: the oblique and equatorial aspects are not measured.
                let pole = degrees("lat_0")?;
                if (pole.abs() - 90.0).abs() > 1e-9 {
                    return None;
                }
                let polar_scale = match degrees("lat_ts") {
                    Some(true_latitude) if (true_latitude.abs() - 90.0).abs() > 1e-9 => {
                        PolarScale::TrueLatitude(true_latitude.abs())
                    }
                    _ => PolarScale::AtPole(scale),
                };
                return Some(Projection::polar_stereographic(polar_scale, false_origin));
            }
            "merc" => {
                // Mercator on the ellipsoid or a sphere, true to scale on `lat_ts` or
                // scaled `k`; not Web Mercator (`+nadgrids=@null`), which the reader
                // measures apart, row by row.
                return (!self.has("nadgrids")).then(|| {
                    Projection::mercator(ellipsoid, degrees("lat_ts"), scale, false_origin[1])
                });
            }
            "aea" => EqualArea::Albers {
                ellipsoid,
                standard_parallels: [degrees("lat_1")?, degrees("lat_2").or(degrees("lat_1"))?],
                origin: [or_zero("lat_0"), or_zero("lon_0")],
                false_easting_northing: false_origin,
            },
            "laea" => EqualArea::Azimuthal {
                ellipsoid,
                centre: [or_zero("lat_0"), or_zero("lon_0")],
                false_easting_northing: false_origin,
            },
            "cea" => EqualArea::Cylindrical {
                ellipsoid,
                standard_parallel: or_zero("lat_ts"),
                central_meridian: or_zero("lon_0"),
                false_easting_northing: false_origin,
            },
            "sinu" => EqualArea::Sinusoidal {
                ellipsoid,
                central_meridian: or_zero("lon_0"),
                false_easting_northing: false_origin,
            },
            "eqearth" => EqualArea::EqualEarth {
                ellipsoid,
                central_meridian: or_zero("lon_0"),
                false_easting_northing: false_origin,
            },
            // Web Mercator by its PROJ string is measured apart, row by row.
            "geocent" => return None,
            _ if self.has("nadgrids") => return None,
            // Any other projection `proj4rs` carries, through its inverse.
            _ => return Projection::numeric(&self.definition()),
        };
        Some(Projection::equal_area(equal_area))
    }

    /// The PROJ string of the terms.
    fn definition(&self) -> String {
        let terms: Vec<String> = self
            .terms
            .iter()
            .map(|(key, value)| {
                if value.is_empty() {
                    format!("+{key}")
                } else {
                    format!("+{key}={value}")
                }
            })
            .collect();
        terms.join(" ")
    }
}

/// The semi-major axis and inverse flattening (0: a sphere) of an ellipsoid by its
/// PROJ name (`+ellps=`); WGS 84's for a name not listed.
pub fn named_ellipsoid_axes(name: &str) -> (f64, f64) {
    match name {
        "GRS80" => (6_378_137.0, 298.257_222_101),
        "clrk66" => (6_378_206.4, 294.978_698_213_898),
        "airy" => (6_377_563.396, 299.324_964_6),
        "mod_airy" => (6_377_340.189, 299.324_964_6),
        "bessel" => (6_377_397.155, 299.152_812_8),
        "bess_nam" => (6_377_483.865, 299.152_812_8),
        "intl" => (6_378_388.0, 297.0),
        "krass" => (6_378_245.0, 298.3),
        "clrk80" => (6_378_249.145, 293.465),
        "clrk80ign" => (6_378_249.2, 293.466_021_293_627),
        "WGS72" => (6_378_135.0, 298.26),
        "WGS66" => (6_378_145.0, 298.25),
        "GRS67" => (6_378_160.0, 298.247_167_427),
        "aust_SA" => (6_378_160.0, 298.25),
        "helmert" => (6_378_200.0, 298.3),
        "evrstSS" => (6_377_298.556, 300.8017),
        "sphere" => (6_370_997.0, 0.0),
        _ => (6_378_137.0, 298.257_223_563),
    }
}

/// The PROJ name of the ellipsoid of an EPSG ellipsoid code (GeoTIFF's
/// GeogEllipsoidGeoKey) or of a geodetic datum code (GeogGeodeticDatumGeoKey) that
/// fixes one.
pub fn epsg_ellipsoid_name(code: u16) -> Option<&'static str> {
    Some(match code {
        7001 | 6277 => "airy",
        7002 | 6299 => "mod_airy",
        7003 | 6618 => "aust_SA",
        7004 | 6314 | 6312 => "bessel",
        7008 | 6267 => "clrk66",
        7011 => "clrk80ign",
        7012 => "clrk80",
        7019 | 6269 | 6258 | 6283 | 6167 => "GRS80",
        7020 => "helmert",
        7022 | 6230 | 6272 => "intl",
        7024 | 6284 => "krass",
        7030 | 6326 => "WGS84",
        7036 => "GRS67",
        7043 | 6322 => "WGS72",
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projected_units_are_read_from_the_registry() {
        let unit = |code| epsg_crs(code).unwrap().metres_per_unit();
        // NAD83 / New York Long Island (ftUS), NAD83 / Texas Central (ft, HARN:
        // international feet), UTM 33N in metres.
        assert!((unit(2263).unwrap() - 1200.0 / 3937.0).abs() < 1e-15);
        assert_eq!(unit(2277).map(|m| (m * 1e6).round()), Some(304_801.0));
        assert_eq!(unit(2868), Some(0.3048));
        assert_eq!(unit(32633), Some(1.0));
        // Geographic and geocentric CRSs have no linear unit; unknown codes no CRS.
        assert_eq!(unit(4326), None);
        assert!(epsg_crs(4326).unwrap().is_geographic());
        assert_eq!(unit(4978), None);
        assert!(epsg_crs(1).is_none());
    }

    #[test]
    fn the_registry_agrees_with_the_projections_listed_by_hand() {
        // Every code `Projection::of_epsg` lists by hand that the registry holds: the
        // same ground scale at points across their domains.
        let codes = [
            3395, 3413, 3995, 3031, 3976, 32661, 5041, 32761, 5042, 2154, 3034, 3978, 3979, 3347,
            3112, 32633, 32760, 25832, 26915, 6339, 26712, 28355, 7855, 3067, 3006, 2100, 27700,
            2193, 31466, 31469, 5070, 5072, 6350, 5069, 3338, 3310, 3083, 3005, 3577, 3035, 6931,
            6932, 3571, 3576, 2163, 3408, 3409, 6933, 3410, 8857, 8859,
        ];
        let points = [
            (500_000.0, 0.0),
            (150_000.0, 1_200_000.0),
            (-1_500_000.0, 2_500_000.0),
            (3_900_000.0, -700_000.0),
        ];
        for code in codes {
            let by_hand = Projection::of_epsg_listed(code).unwrap();
            let registry = epsg_crs(code).and_then(|crs| crs.projection());
            let registry = registry.unwrap_or_else(|| panic!("EPSG:{code}"));
            for (x, y) in points {
                let (a, b) = (by_hand.axis_scales(x, y).0, registry.axis_scales(x, y).0);
                for (a, b) in a.into_iter().zip(b) {
                    let agree =
                        a == b || (a - b).abs() <= 1e-6 * a.abs() || (a.is_nan() && b.is_nan());
                    assert!(
                        agree,
                        "EPSG:{code} at ({x}, {y}): {a} by hand, {b} registry"
                    );
                }
            }
        }
    }

    #[test]
    fn codes_not_listed_by_hand_are_measured_from_the_registry() {
        // NSIDC's Sea Ice Polar Stereographic North on Hughes 1980 (3411), true at
        // 70° N: at the pole a unit spans more than a ground metre.
        let polar = Projection::of_epsg(3411).unwrap();
        assert!(polar.axis_scales(0.0, 0.0).0[0] > 1.01);
        // Oblique stereographic (the Dutch RD grid) and Krovak are measured through
        // PROJ's inverse: RD is scaled 0.9999079 at Amersfoort (155 km, 463 km), and
        // Krovak 0.9999 on its standard parallel, which crosses Prague (−743 km,
        // −1043 km) within 0.1 %.
        let rd = Projection::of_epsg(28992)
            .unwrap()
            .axis_scales(155_000.0, 463_000.0);
        assert!((rd.0[0] - 1.0 / 0.999_907_9).abs() < 1e-6, "{rd:?}");
        let krovak = Projection::of_epsg(5514)
            .unwrap()
            .axis_scales(-743_000.0, -1_043_000.0);
        assert!(
            krovak.0.iter().all(|s| (s - 1.0).abs() < 1e-3),
            "{krovak:?}"
        );
        // Web Mercator is measured apart, never as World Mercator.
        assert!(Projection::of_epsg(3857).is_none());
    }

    #[test]
    fn every_projection_of_the_registry_is_near_true_scale_at_its_origin() {
        // Thousands of codes (State Plane, national and polar grids): at the false
        // origin each is within a factor 2 of true scale and square, but cones whose
        // origin is a pole (their apex, where the scale is unbounded).
        let mut measured = 0;
        for code in 1..=u16::MAX {
            let Some(crs) = epsg_crs(code) else { continue };
            let Some(projection) = crs.projection() else {
                continue;
            };
            measured += 1;
            let apex = crs.projection_name() == "lcc"
                && crs.number("lat_0").is_some_and(|l| l.abs() == 90.0);
            let origin = [crs.number("x_0"), crs.number("y_0")].map(|v| v.unwrap_or(0.0));
            let ([sx, sy], skew) = projection.axis_scales(origin[0], origin[1]);
            let sane = [sx, sy].iter().all(|s| (0.5..2.0).contains(s)) && skew.abs() < 0.01;
            // Krovak's false origin lies outside the cone it projects onto: no scale
            // there (a raster there reads in the frame's units).
            let outside = crs.projection_name() == "krovak" && sx.is_nan() && sy.is_nan();
            assert!(
                sane || apex || outside,
                "EPSG:{code}: {sx} × {sy}, skew {skew}"
            );
        }
        assert!(measured > 5000, "{measured}");
    }
}
