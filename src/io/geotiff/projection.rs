//! The projection a GeoTIFF's GeoKeys name, where its metre is not a ground metre
//! (`grid::Projection`): by EPSG code, a Lambert conformal conic, Transverse Mercator,
//! Albers, LAEA or world projection the keys define by their parameters (GDAL writes
//! those for ESRI's codes, such as 102003 and 102004, and PROJ strings), or one a WKT
//! citation gives (an ESRI PE string, a sidecar's CRS with no code), and the ground
//! metres per projected metre it has at the raster's centre.

use std::path::Path;

use crate::grid::{Ellipsoid, EqualArea, GeoRef, GroundScale, Projection, TRUE_SCALE_TOLERANCE};

const PROJECTED_CRS: u16 = 3072;
const GEOGRAPHIC_CRS: u16 = 2048;
const GEOG_DATUM: u16 = 2050;
const GEOG_ANGULAR_UNITS: u16 = 2054;
const GEOG_ELLIPSOID: u16 = 2056;
const SEMI_MAJOR_AXIS: u16 = 2057;
const SEMI_MINOR_AXIS: u16 = 2058;
const INVERSE_FLATTENING: u16 = 2059;
const COORDINATE_TRANSFORMATION: u16 = 3075;
const STANDARD_PARALLEL_1: u16 = 3078;
const STANDARD_PARALLEL_2: u16 = 3079;
const NATURAL_ORIGIN_LONGITUDE: u16 = 3080;
const NATURAL_ORIGIN_LATITUDE: u16 = 3081;
const FALSE_EASTING: u16 = 3082;
const FALSE_NORTHING: u16 = 3083;
const FALSE_ORIGIN_LONGITUDE: u16 = 3084;
const FALSE_ORIGIN_LATITUDE: u16 = 3085;
const FALSE_ORIGIN_EASTING: u16 = 3086;
const FALSE_ORIGIN_NORTHING: u16 = 3087;
const CENTER_LONGITUDE: u16 = 3088;
const CENTER_LATITUDE: u16 = 3089;
const CENTER_EASTING: u16 = 3090;
const CENTER_NORTHING: u16 = 3091;
const SCALE_AT_NATURAL_ORIGIN: u16 = 3092;
/// GeoTIFF's codes for the coordinate transformations (CT_TransverseMercator,
/// CT_LambertConfConic_2SP and _1SP, CT_LambertAzimEqualArea, CT_AlbersEqualArea).
const TRANSVERSE_MERCATOR: u16 = 1;
const MERCATOR: u16 = 7;
const POLAR_STEREOGRAPHIC: u16 = 15;
const STRAIGHT_VERTICAL_POLE_LONGITUDE: u16 = 3095;
const LAMBERT_CONFORMAL_2SP: u16 = 8;
const LAMBERT_CONFORMAL_1SP: u16 = 9;
const LAMBERT_AZIMUTHAL_EQUAL_AREA: u16 = 10;
const ALBERS_EQUAL_AREA: u16 = 11;
const AZIMUTHAL_EQUIDISTANT: u16 = 12;
const EQUIDISTANT_CONIC: u16 = 13;
const STEREOGRAPHIC: u16 = 14;
const OBLIQUE_STEREOGRAPHIC: u16 = 16;
const EQUIRECTANGULAR: u16 = 17;
const CASSINI_SOLDNER: u16 = 18;
const GNOMONIC: u16 = 19;
const ORTHOGRAPHIC: u16 = 21;
const POLYCONIC: u16 = 22;
const ROBINSON: u16 = 23;
const SINUSOIDAL: u16 = 24;
const VAN_DER_GRINTEN: u16 = 25;
const CYLINDRICAL_EQUAL_AREA: u16 = 28;
#[cfg(test)]
const ANGULAR_RADIAN: u16 = 9101;

/// The GeoKeys a reader looks up: short values, double parameters, and the ASCII
/// citations (GeoAsciiParams, where GDAL writes the ESRI PE string of a projection
/// GeoTIFF has no code for, such as Mollweide).
pub(super) struct GeoKeys<'a> {
    pub short: &'a dyn Fn(u16) -> Option<u16>,
    pub double: &'a dyn Fn(u16) -> Option<f64>,
    pub citations: &'a str,
}

impl GeoKeys<'_> {
    /// Readers of the double parameters: angles in degrees (from the geographic CRS's
    /// unit: radians, grads), lengths in metres (from the CRS's, `metres_per_unit`).
    fn in_degrees_and_metres(
        &self,
        metres_per_unit: f64,
    ) -> (
        impl Fn(u16) -> Option<f64> + '_,
        impl Fn(u16) -> Option<f64> + '_,
    ) {
        let per_unit = (self.short)(GEOG_ANGULAR_UNITS)
            .and_then(super::degrees_per_angular_unit)
            .unwrap_or(1.0);
        let double = self.double;
        (
            move |id: u16| double(id).map(|v| v * per_unit),
            move |id: u16| double(id).map(|v| v * metres_per_unit),
        )
    }
}

/// The projection the keys name, where it is one whose scale the reader corrects;
/// `metres_per_unit` converts false eastings and northings from the CRS's unit.
pub(super) fn of_keys(keys: &GeoKeys, metres_per_unit: f64) -> Option<Projection> {
    if let Some(projection) = (keys.short)(PROJECTED_CRS).and_then(Projection::of_epsg) {
        return Some(projection);
    }
    let double = keys.double;
    let (degrees, metres) = keys.in_degrees_and_metres(metres_per_unit);
    let either = |a: Option<f64>, b: Option<f64>| a.or(b).unwrap_or(0.0);
    let ellipsoid = ellipsoid_of(keys);
    let Some(transformation) = (keys.short)(COORDINATE_TRANSFORMATION) else {
        let given = (keys.double)(SEMI_MAJOR_AXIS)
            .is_some()
            .then_some(ellipsoid);
        return of_wkt_citation(keys.citations, given, metres_per_unit);
    };
    let central_meridian = either(degrees(CENTER_LONGITUDE), degrees(NATURAL_ORIGIN_LONGITUDE));
    let false_easting_northing = [
        metres(FALSE_EASTING).unwrap_or(0.0),
        metres(FALSE_NORTHING).unwrap_or(0.0),
    ];
    let equal_area = match transformation {
        TRANSVERSE_MERCATOR => {
            return Some(Projection::transverse_mercator(
                double(SCALE_AT_NATURAL_ORIGIN).unwrap_or(1.0),
                false_easting_northing[0],
            ));
        }
        LAMBERT_CONFORMAL_2SP => {
            return Some(Projection::lambert_conformal(
                [
                    degrees(STANDARD_PARALLEL_1)?,
                    degrees(STANDARD_PARALLEL_2).or(degrees(STANDARD_PARALLEL_1))?,
                ],
                1.0,
                either(
                    degrees(FALSE_ORIGIN_LATITUDE),
                    degrees(NATURAL_ORIGIN_LATITUDE),
                ),
                [
                    either(metres(FALSE_ORIGIN_EASTING), metres(FALSE_EASTING)),
                    either(metres(FALSE_ORIGIN_NORTHING), metres(FALSE_NORTHING)),
                ],
            ));
        }
        MERCATOR => {
            // GDAL writes Mercator (2SP)'s latitude of true scale as the first
            // standard parallel, and (1SP)'s scale at the natural origin.
            return Some(Projection::mercator(
                ellipsoid,
                degrees(STANDARD_PARALLEL_1),
                double(SCALE_AT_NATURAL_ORIGIN).unwrap_or(1.0),
                false_easting_northing[1],
            ));
        }
        POLAR_STEREOGRAPHIC => {
            // GDAL writes a latitude of true scale (EPSG's variant B) as the natural
            // origin's latitude; at a pole it is variant A, with its scale there.
            let latitude = degrees(NATURAL_ORIGIN_LATITUDE)?;
            return Some(if (latitude.abs() - 90.0).abs() > 1e-9 {
                Projection::polar_stereographic_true_at(latitude.abs(), false_easting_northing)
            } else {
                Projection::polar_stereographic_scaled_at_pole(
                    double(SCALE_AT_NATURAL_ORIGIN).unwrap_or(1.0),
                    false_easting_northing,
                )
            });
        }
        LAMBERT_CONFORMAL_1SP => {
            let latitude = degrees(NATURAL_ORIGIN_LATITUDE)?;
            return Some(Projection::lambert_conformal(
                [latitude; 2],
                double(SCALE_AT_NATURAL_ORIGIN).unwrap_or(1.0),
                latitude,
                [
                    metres(FALSE_EASTING).unwrap_or(0.0),
                    metres(FALSE_NORTHING).unwrap_or(0.0),
                ],
            ));
        }
        ALBERS_EQUAL_AREA => EqualArea::Albers {
            ellipsoid,
            standard_parallels: [
                degrees(STANDARD_PARALLEL_1)?,
                degrees(STANDARD_PARALLEL_2).or(degrees(STANDARD_PARALLEL_1))?,
            ],
            origin: [
                either(
                    degrees(NATURAL_ORIGIN_LATITUDE),
                    degrees(FALSE_ORIGIN_LATITUDE),
                ),
                either(
                    degrees(NATURAL_ORIGIN_LONGITUDE),
                    degrees(FALSE_ORIGIN_LONGITUDE),
                ),
            ],
            false_easting_northing: [
                either(metres(FALSE_EASTING), metres(FALSE_ORIGIN_EASTING)),
                either(metres(FALSE_NORTHING), metres(FALSE_ORIGIN_NORTHING)),
            ],
        },
        LAMBERT_AZIMUTHAL_EQUAL_AREA => EqualArea::Azimuthal {
            ellipsoid,
            centre: [
                either(degrees(CENTER_LATITUDE), degrees(NATURAL_ORIGIN_LATITUDE)),
                either(degrees(CENTER_LONGITUDE), degrees(NATURAL_ORIGIN_LONGITUDE)),
            ],
            false_easting_northing: [
                either(metres(FALSE_EASTING), metres(CENTER_EASTING)),
                either(metres(FALSE_NORTHING), metres(CENTER_NORTHING)),
            ],
        },
        SINUSOIDAL => EqualArea::Sinusoidal {
            ellipsoid,
            central_meridian,
            false_easting_northing,
        },
        CYLINDRICAL_EQUAL_AREA => EqualArea::Cylindrical {
            ellipsoid,
            standard_parallel: degrees(STANDARD_PARALLEL_1).unwrap_or(0.0),
            central_meridian,
            false_easting_northing,
        },
        // Any other method PROJ carries, measured through its inverse.
        _ => {
            return proj_string(keys, metres_per_unit, false).and_then(|p| Projection::numeric(&p));
        }
    };
    Some(Projection::equal_area(equal_area))
}

/// A PROJ string of the CRS the keys define by their parameters, for CRSs with no
/// EPSG code: a geographic CRS, or a projection of the methods GeoTIFF codes that
/// PROJ carries (Transverse Mercator, Lambert conformal of one or two parallels,
/// Albers, Lambert azimuthal, Mercator, polar stereographic, sinusoidal, cylindrical
/// equal-area, azimuthal equidistant, equidistant conic and cylindrical, stereographic
/// and oblique stereographic, Cassini, gnomonic, orthographic, polyconic, Robinson,
/// Van der Grinten),
/// on the keys' ellipsoid. Coordinates in the CRS's linear unit
/// (`metres_per_unit`), as the frame keeps them. `None` for any other method.
pub(super) fn proj_string(
    keys: &GeoKeys,
    metres_per_unit: f64,
    geographic: bool,
) -> Option<String> {
    let double = keys.double;
    let (degrees, metres) = keys.in_degrees_and_metres(metres_per_unit);
    let first = |ids: &[u16], of: &dyn Fn(u16) -> Option<f64>| {
        ids.iter().find_map(|&id| of(id)).unwrap_or(0.0)
    };
    let ellipsoid = ellipsoid_of(keys);
    let shape = format!(
        "+a={} +b={}",
        ellipsoid.a,
        ellipsoid.a * (1.0 - ellipsoid.e2).sqrt()
    );
    if geographic {
        return Some(format!("+proj=longlat {shape} +no_defs"));
    }
    let x_0 = first(
        &[FALSE_EASTING, FALSE_ORIGIN_EASTING, CENTER_EASTING],
        &metres,
    );
    let y_0 = first(
        &[FALSE_NORTHING, FALSE_ORIGIN_NORTHING, CENTER_NORTHING],
        &metres,
    );
    let lon_0 = first(
        &[
            NATURAL_ORIGIN_LONGITUDE,
            FALSE_ORIGIN_LONGITUDE,
            CENTER_LONGITUDE,
        ],
        &degrees,
    );
    let lat_0 = first(
        &[
            NATURAL_ORIGIN_LATITUDE,
            FALSE_ORIGIN_LATITUDE,
            CENTER_LATITUDE,
        ],
        &degrees,
    );
    let k_0 = double(SCALE_AT_NATURAL_ORIGIN).unwrap_or(1.0);
    let parallels = || -> Option<(f64, f64)> {
        let one = degrees(STANDARD_PARALLEL_1)?;
        Some((one, degrees(STANDARD_PARALLEL_2).unwrap_or(one)))
    };
    let method = match (keys.short)(COORDINATE_TRANSFORMATION)? {
        TRANSVERSE_MERCATOR => format!("+proj=tmerc +lat_0={lat_0} +lon_0={lon_0} +k_0={k_0}"),
        LAMBERT_CONFORMAL_2SP => {
            let (lat_1, lat_2) = parallels()?;
            format!("+proj=lcc +lat_1={lat_1} +lat_2={lat_2} +lat_0={lat_0} +lon_0={lon_0}")
        }
        LAMBERT_CONFORMAL_1SP => {
            format!("+proj=lcc +lat_1={lat_0} +lat_0={lat_0} +lon_0={lon_0} +k_0={k_0}")
        }
        ALBERS_EQUAL_AREA => {
            let (lat_1, lat_2) = parallels()?;
            format!("+proj=aea +lat_1={lat_1} +lat_2={lat_2} +lat_0={lat_0} +lon_0={lon_0}")
        }
        LAMBERT_AZIMUTHAL_EQUAL_AREA => format!("+proj=laea +lat_0={lat_0} +lon_0={lon_0}"),
        MERCATOR => match degrees(STANDARD_PARALLEL_1) {
            Some(lat_ts) => format!("+proj=merc +lat_ts={lat_ts} +lon_0={lon_0}"),
            None => format!("+proj=merc +lon_0={lon_0} +k_0={k_0}"),
        },
        POLAR_STEREOGRAPHIC => {
            let pole = if lat_0 < 0.0 { -90.0 } else { 90.0 };
            let lon_0 = degrees(STRAIGHT_VERTICAL_POLE_LONGITUDE).unwrap_or(lon_0);
            if lat_0.abs() < 90.0 {
                format!("+proj=stere +lat_0={pole} +lat_ts={lat_0} +lon_0={lon_0}")
            } else {
                format!("+proj=stere +lat_0={pole} +lon_0={lon_0} +k_0={k_0}")
            }
        }
        SINUSOIDAL => format!("+proj=sinu +lon_0={lon_0}"),
        AZIMUTHAL_EQUIDISTANT => format!("+proj=aeqd +lat_0={lat_0} +lon_0={lon_0}"),
        EQUIDISTANT_CONIC => {
            let (lat_1, lat_2) = parallels()?;
            format!("+proj=eqdc +lat_1={lat_1} +lat_2={lat_2} +lat_0={lat_0} +lon_0={lon_0}")
        }
        STEREOGRAPHIC => format!("+proj=stere +lat_0={lat_0} +lon_0={lon_0} +k_0={k_0}"),
        OBLIQUE_STEREOGRAPHIC => {
            format!("+proj=sterea +lat_0={lat_0} +lon_0={lon_0} +k_0={k_0}")
        }
        EQUIRECTANGULAR => format!(
            "+proj=eqc +lat_ts={} +lat_0={lat_0} +lon_0={lon_0}",
            degrees(STANDARD_PARALLEL_1).unwrap_or(0.0)
        ),
        CASSINI_SOLDNER => format!("+proj=cass +lat_0={lat_0} +lon_0={lon_0}"),
        GNOMONIC => format!("+proj=gnom +lat_0={lat_0} +lon_0={lon_0}"),
        ORTHOGRAPHIC => format!("+proj=ortho +lat_0={lat_0} +lon_0={lon_0}"),
        POLYCONIC => format!("+proj=poly +lat_0={lat_0} +lon_0={lon_0}"),
        ROBINSON => format!("+proj=robin +lon_0={lon_0}"),
        VAN_DER_GRINTEN => format!("+proj=vandg +lon_0={lon_0}"),
        CYLINDRICAL_EQUAL_AREA => format!(
            "+proj=cea +lat_ts={} +lon_0={lon_0}",
            degrees(STANDARD_PARALLEL_1).unwrap_or(0.0)
        ),
        _ => return None,
    };
    Some(format!(
        "{method} +x_0={x_0} +y_0={y_0} {shape} +to_meter={metres_per_unit} +no_defs"
    ))
}

/// The projection of a WKT CRS in the citations, ESRI's, OGC's WKT 1 or WKT 2: GDAL
/// writes an ESRI PE string for projections GeoTIFF has no code for (Mollweide,
/// ESRI:54009), and sidecars (ArcGIS's `.aux.xml`) hold CRSs with no EPSG code. Its
/// PROJECTION or METHOD and its PARAMETERs (names in any of the dialects, any case),
/// false eastings and northings in the CRS's units, on its SPHEROID or ELLIPSOID where
/// the keys give no ellipsoid.
pub(super) fn of_wkt_citation(
    citations: &str,
    ellipsoid: Option<Ellipsoid>,
    metres_per_unit: f64,
) -> Option<Projection> {
    let normal = |name: &str| {
        name.trim()
            .trim_matches('"')
            .to_ascii_lowercase()
            .replace(' ', "_")
            .replace(['(', ')'], "")
    };
    // Each `KEYWORD["name",numbers...]` of the string, in order.
    let elements = |keyword: &str| -> Vec<(String, Vec<f64>)> {
        let key = format!("{keyword}[");
        citations
            .match_indices(&key)
            .filter(|(at, _)| {
                // Whole keywords only (not the end of a longer one).
                !citations[..*at].ends_with(|c: char| c.is_ascii_alphabetic())
            })
            .filter_map(|(at, _)| {
                let rest = &citations[at + key.len()..];
                let body = &rest[..rest.find(']')?];
                let mut fields = body.split(',');
                let name = normal(fields.next()?);
                Some((name, fields.filter_map(|v| v.trim().parse().ok()).collect()))
            })
            .collect()
    };
    // ESRI's world CRSs that GDAL writes by name alone (`World_Van_der_Grinten_I`,
    // ESRI:54029: no PE string), centred on Greenwich.
    let esri_world = || {
        let name = citations.split('|').next()?.trim().strip_prefix("World_")?;
        Some(normal(name))
    };
    let projection = elements("PROJECTION")
        .into_iter()
        .chain(elements("METHOD"))
        .map(|(name, _)| name)
        .next()
        .or_else(esri_world)?;
    // GDAL's WKT 1 for a CRS it has no name for holds its PROJ string.
    if projection == "custom_proj4" {
        let key = "EXTENSION[\"PROJ4\",\"";
        let rest = &citations[citations.find(key)? + key.len()..];
        return Projection::numeric(&rest[..rest.find('"')?]);
    }
    let parameters = elements("PARAMETER");
    // A parameter's value and, in WKT 2, its own unit's factor (to radians or metres).
    let parameter = |names: &[&str]| {
        parameters
            .iter()
            .find(|(name, values)| names.contains(&name.as_str()) && !values.is_empty())
            .map(|(_, values)| (values[0], values.get(1).copied()))
    };
    let degrees = |names: &[&str]| {
        parameter(names).map(|(value, radians)| radians.map_or(value, |r| (value * r).to_degrees()))
    };
    let metres = |names: &[&str]| {
        parameter(names).map_or(0.0, |(value, factor)| {
            value * factor.unwrap_or(metres_per_unit)
        })
    };
    let spheroid = elements("SPHEROID")
        .into_iter()
        .chain(elements("ELLIPSOID"));
    let ellipsoid = ellipsoid.unwrap_or_else(|| match spheroid.into_iter().next() {
        Some((_, axes)) if axes.len() >= 2 && axes[0] > 0.0 => {
            Ellipsoid::from_inverse_flattening(axes[0], axes[1])
        }
        _ => Ellipsoid::WGS84,
    });
    let false_origin = [
        metres(&["false_easting", "easting_at_false_origin"]),
        metres(&["false_northing", "northing_at_false_origin"]),
    ];
    let central_meridian = degrees(&[
        "central_meridian",
        "longitude_of_center",
        "longitude_of_natural_origin",
        "longitude_of_false_origin",
        "longitude_of_origin",
    ])
    .unwrap_or(0.0);
    let origin_latitude = degrees(&[
        "latitude_of_origin",
        "latitude_of_center",
        "latitude_of_natural_origin",
        "latitude_of_false_origin",
    ])
    .unwrap_or(0.0);
    let first_parallel = degrees(&[
        "standard_parallel_1",
        "latitude_of_1st_standard_parallel",
        "latitude_of_standard_parallel",
    ]);
    let parallels = first_parallel.map(|p| {
        [
            p,
            degrees(&["standard_parallel_2", "latitude_of_2nd_standard_parallel"]).unwrap_or(p),
        ]
    });
    let scale =
        parameter(&["scale_factor", "scale_factor_at_natural_origin"]).map_or(1.0, |(k, _)| k);
    let equal_area = match projection.as_str() {
        "transverse_mercator" | "gauss_kruger" => {
            return Some(Projection::transverse_mercator(scale, false_origin[0]));
        }
        "lambert_conformal_conic"
        | "lambert_conformal_conic_1sp"
        | "lambert_conformal_conic_2sp"
        | "lambert_conic_conformal_1sp"
        | "lambert_conic_conformal_2sp" => {
            return Some(Projection::lambert_conformal(
                parallels.unwrap_or([origin_latitude; 2]),
                scale,
                origin_latitude,
                false_origin,
            ));
        }
        "polar_stereographic_variant_a" => {
            return Some(Projection::polar_stereographic_scaled_at_pole(
                scale,
                false_origin,
            ));
        }
        "stereographic_north_pole"
        | "stereographic_south_pole"
        | "polar_stereographic_variant_b" => {
            return Some(Projection::polar_stereographic_true_at(
                first_parallel?.abs(),
                false_origin,
            ));
        }
        "mercator" | "mercator_1sp" | "mercator_2sp" | "mercator_variant_a"
        | "mercator_variant_b" => {
            // True to scale on a parallel or scaled on the equator, on the ellipsoid
            // or the sphere (Web Mercator by its code is measured apart, row by row).
            return Some(Projection::mercator(
                ellipsoid,
                first_parallel,
                scale,
                false_origin[1],
            ));
        }
        "mollweide" => EqualArea::Mollweide {
            radius: ellipsoid.a,
            central_meridian,
            false_easting_northing: false_origin,
        },
        "albers" | "albers_conic_equal_area" | "albers_equal_area" => EqualArea::Albers {
            ellipsoid,
            standard_parallels: parallels?,
            origin: [origin_latitude, central_meridian],
            false_easting_northing: false_origin,
        },
        "lambert_azimuthal_equal_area" => EqualArea::Azimuthal {
            ellipsoid,
            centre: [origin_latitude, central_meridian],
            false_easting_northing: false_origin,
        },
        "sinusoidal" => EqualArea::Sinusoidal {
            ellipsoid,
            central_meridian,
            false_easting_northing: false_origin,
        },
        "cylindrical_equal_area" | "lambert_cylindrical_equal_area" | "behrmann" => {
            EqualArea::Cylindrical {
                ellipsoid,
                standard_parallel: first_parallel.unwrap_or(if projection == "behrmann" {
                    30.0
                } else {
                    0.0
                }),
                central_meridian,
                false_easting_northing: false_origin,
            }
        }
        "equal_earth" => EqualArea::EqualEarth {
            ellipsoid,
            central_meridian,
            false_easting_northing: false_origin,
        },
        other => {
            // Any other method PROJ carries, measured through its inverse.
            let method = match other {
                "double_stereographic" | "oblique_stereographic" => format!("sterea +k_0={scale}"),
                "stereographic" => format!("stere +k_0={scale}"),
                "azimuthal_equidistant" => "aeqd".to_string(),
                "equidistant_conic" => {
                    let [lat_1, lat_2] = parallels?;
                    format!("eqdc +lat_1={lat_1} +lat_2={lat_2}")
                }
                "equidistant_cylindrical" | "equirectangular" | "plate_carree" => {
                    format!("eqc +lat_ts={}", first_parallel.unwrap_or(0.0))
                }
                "cassini" | "cassini_soldner" => "cass".to_string(),
                "gnomonic" => "gnom".to_string(),
                "orthographic" => "ortho".to_string(),
                "polyconic" => "poly".to_string(),
                "robinson" => "robin".to_string(),
                "miller_cylindrical" => "mill".to_string(),
                // World maps on a sphere, as GDAL names them in WKT 1, WKT 2 and ESRI's.
                "eckert_i" => "eck1".to_string(),
                "eckert_ii" => "eck2".to_string(),
                "eckert_iii" => "eck3".to_string(),
                "eckert_iv" => "eck4".to_string(),
                "eckert_v" => "eck5".to_string(),
                "eckert_vi" => "eck6".to_string(),
                "wagner_iv" => "wag4".to_string(),
                "vandergrinten" | "van_der_grinten" | "van_der_grinten_i" => "vandg".to_string(),
                "winkel_i" => format!("wink1 +lat_ts={}", first_parallel.unwrap_or(0.0)),
                "interrupted_goode_homolosine" => "igh".to_string(),
                // ESRI's option 1 is the land's interruptions, 2 the oceans'.
                "goode_homolosine" => match parameter(&["option"]).map(|(o, _)| o) {
                    Some(1.0) => "igh".to_string(),
                    Some(o) if o != 0.0 => return None,
                    _ => "goode".to_string(),
                },
                "winkel_tripel" => format!("wintri +lat_1={}", first_parallel.unwrap_or(50.467)),
                "aitoff" => "aitoff".to_string(),
                "hammer_aitoff" => "hammer".to_string(),
                "craster_parabolic" => "crast".to_string(),
                "natural_earth" => "natearth".to_string(),
                "kavrayskiy_vii" => "kav7".to_string(),
                "patterson" => "patterson".to_string(),
                "times" => "times".to_string(),
                "gall_stereographic" => "gall".to_string(),
                // WKT 2's and ESRI's names for a PROJ method with no other (`PROJ kav7`).
                other => match other.strip_prefix("proj_") {
                    Some(method) if method.chars().all(|c| c.is_ascii_alphanumeric()) => {
                        method.to_string()
                    }
                    _ => return None,
                },
            };
            let b = ellipsoid.a * (1.0 - ellipsoid.e2).sqrt();
            return Projection::numeric(&format!(
                "+proj={method} +lat_0={origin_latitude} +lon_0={central_meridian} +x_0={} \
                 +y_0={} +a={} +b={b}",
                false_origin[0], false_origin[1], ellipsoid.a
            ));
        }
    };
    Some(Projection::equal_area(equal_area))
}

/// The ellipsoid the keys give: its axes, else its EPSG code, its datum's, or its
/// geographic CRS's (whose classic codes are their datum's less 2000); WGS 84
/// otherwise (GRS 80, NAD83's and ETRS89's, is the same to our precision).
fn ellipsoid_of(keys: &GeoKeys) -> Ellipsoid {
    let Some(a) = (keys.double)(SEMI_MAJOR_AXIS).filter(|a| *a > 0.0) else {
        let named = [GEOG_ELLIPSOID, GEOG_DATUM]
            .into_iter()
            .filter_map(|key| (keys.short)(key))
            .chain((keys.short)(GEOGRAPHIC_CRS).and_then(|crs| crs.checked_add(2000)))
            .find_map(crate::grid::epsg_ellipsoid_name);
        return named.map_or(Ellipsoid::WGS84, |name| {
            let (a, inverse_flattening) = crate::grid::named_ellipsoid_axes(name);
            Ellipsoid::from_inverse_flattening(a, inverse_flattening)
        });
    };
    match (
        (keys.double)(INVERSE_FLATTENING),
        (keys.double)(SEMI_MINOR_AXIS),
    ) {
        (Some(inverse_flattening), _) => Ellipsoid::from_inverse_flattening(a, inverse_flattening),
        (None, Some(b)) if b > 0.0 && b <= a => Ellipsoid {
            a,
            e2: 1.0 - (b / a).powi(2),
        },
        _ => Ellipsoid::sphere(a),
    }
}

/// Sets `geo`'s ground metres per frame unit: the CRS's linear unit (`metres_per_unit`:
/// 0.3048 for international feet, whose coordinates the frame keeps) times
/// `projection`'s scale at the raster's centre. Warns where the scale varies by more
/// than 5 % across the raster or where the axes are more than 3° from square on the
/// ground (diagonal steps are then measured that much off).
pub(super) fn set_ground_scale(
    geo: &mut GeoRef,
    projection: Option<&Projection>,
    metres_per_unit: f64,
    path: &Path,
) {
    let unit = |geo: &mut GeoRef| {
        geo.ground_scale =
            (metres_per_unit != 1.0).then_some(GroundScale::Uniform(metres_per_unit));
    };
    let Some(projection) = projection else {
        // Not measured: a national grid, true to scale over its country.
        return unit(geo);
    };
    let [x0, y0, x1, y1] = geo.bounds().map(|v| v * metres_per_unit);
    let ([sx, sy], skew) = projection.axis_scales((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    if !(sx.is_finite() && sy.is_finite() && sx > 0.0 && sy > 0.0) {
        // Outside the projection's domain: the frame's units as they are.
        return unit(geo);
    }
    if [sx, sy]
        .iter()
        .all(|s| (s - 1.0).abs() <= TRUE_SCALE_TOLERANCE)
    {
        // True to scale within 0.1 % (UTM inside its zone, a State Plane grid): the
        // frame's units are read as ground lengths.
        return unit(geo);
    }
    let [gx, gy] = [sx, sy].map(|s| s * metres_per_unit);
    geo.ground_scale = Some(if (gx - gy).abs() <= 1e-12 * gx {
        GroundScale::Uniform(gx)
    } else {
        GroundScale::PerAxis([gx, gy])
    });
    let variation = [(x0, y0), (x0, y1), (x1, y0), (x1, y1)]
        .into_iter()
        .map(|(x, y)| projection.axis_scales(x, y).0)
        .map(|[cx, cy]| (cx / sx - 1.0).abs().max((cy / sy - 1.0).abs()))
        .fold(
            0.0,
            |a: f64, b| if b.is_nan() { f64::INFINITY } else { a.max(b) },
        );
    // A CRS with no EPSG code has the frame "map".
    let code = if geo.frame == "map" {
        "user-defined".to_string()
    } else {
        geo.frame.clone()
    };
    if variation.is_infinite() {
        tracing::warn!(
            "{}: corners of the raster lie outside the projection's ({code}) domain; \
             lengths are measured at its centre: reproject it (gdalwarp) for exact ones",
            path.display()
        );
    } else if variation > 0.05 {
        tracing::warn!(
            "{}: the projection's ({code}) scale varies by up to {:.0} % across the \
             raster; lengths are measured at its centre: reproject it (gdalwarp) for \
             exact ones",
            path.display(),
            100.0 * variation
        );
    }
    if skew.abs() > 3f64.to_radians().sin() {
        tracing::warn!(
            "{}: the projection's ({code}) grid axes are {:.1}° from square on the ground \
             at the raster's centre; diagonal steps are measured as if square: reproject \
             it (gdalwarp) for exact ones",
            path.display(),
            skew.asin().to_degrees().abs()
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `of_keys` over these short keys and double parameters.
    fn projection(short: &[(u16, u16)], doubles: &[(u16, f64)], metres: f64) -> Projection {
        let short_key = |id: u16| short.iter().find(|k| k.0 == id).map(|k| k.1);
        let double_key = |id: u16| doubles.iter().find(|k| k.0 == id).map(|k| k.1);
        let keys = GeoKeys {
            short: &short_key,
            double: &double_key,
            citations: "",
        };
        of_keys(&keys, metres).expect("a projection the reader measures")
    }

    #[test]
    fn mollweide_is_read_from_the_esri_string_in_the_citations() {
        let pe = "ESRI PE String = PROJCS[\"World_Mollweide\",GEOGCS[\"GCS_WGS_1984\",\
                  DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",6378137.0,298.257223563]],\
                  PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]],\
                  PROJECTION[\"Mollweide\"],PARAMETER[\"False_Easting\",1000.0],\
                  PARAMETER[\"False_Northing\",0.0],PARAMETER[\"Central_Meridian\",-90.0],\
                  UNIT[\"Meter\",1.0]]|";
        let Some(projection) = of_wkt_citation(pe, None, 1.0) else {
            panic!("Mollweide in {pe}");
        };
        // At the equator on its central meridian (the false easting away) Mollweide's
        // sphere spans π/(2√2) ≈ 1.111 ground metres per projected metre east and
        // 2√2/π ≈ 0.900 north, 0.894 on WGS 84, whose meridian curves less there.
        let ([sx, sy], skew) = projection.axis_scales(1000.0, 0.0);
        assert!(
            (sx - 1.1107).abs() < 1e-3 && (sy - 0.8943).abs() < 1e-3,
            "{sx} {sy}"
        );
        assert!(skew.abs() < 1e-9);
        assert!(of_wkt_citation("WGS 84 / UTM zone 33N|", None, 1.0).is_none());
    }

    #[test]
    fn wkt_projections_are_read_in_either_dialect() {
        let scales = |projection: Projection| projection.axis_scales(1.0e6, 1.5e6).0;
        // Conus Albers in ESRI's WKT and in OGC's (GDAL's for a CRS with no code):
        // EPSG:5070's scales.
        let conus = scales(Projection::of_epsg(5070).unwrap());
        let esri = r#"PROJCS["NAD_1983_Contiguous_USA_Albers",GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],PROJECTION["Albers"],PARAMETER["False_Easting",0.0],PARAMETER["False_Northing",0.0],PARAMETER["Central_Meridian",-96.0],PARAMETER["Standard_Parallel_1",29.5],PARAMETER["Standard_Parallel_2",45.5],PARAMETER["Latitude_Of_Origin",23.0],UNIT["Meter",1.0]]"#;
        let ogc = r#"PROJCS["unnamed",GEOGCS["NAD83",DATUM["North_American_Datum_1983",SPHEROID["GRS 1980",6378137,298.257222101]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]],PROJECTION["Albers_Conic_Equal_Area"],PARAMETER["latitude_of_center",23],PARAMETER["longitude_of_center",-96],PARAMETER["standard_parallel_1",29.5],PARAMETER["standard_parallel_2",45.5],PARAMETER["false_easting",0],PARAMETER["false_northing",0],UNIT["metre",1]]"#;
        let wkt2 = r#"PROJCRS["unknown",BASEGEOGCRS["unknown",DATUM["North American Datum 1983",ELLIPSOID["GRS 1980",6378137,298.257222101,LENGTHUNIT["metre",1]],ID["EPSG",6269]],PRIMEM["Greenwich",0,ANGLEUNIT["degree",0.0174532925199433],ID["EPSG",8901]]],CONVERSION["unknown",METHOD["Albers Equal Area",ID["EPSG",9822]],PARAMETER["Latitude of false origin",23,ANGLEUNIT["degree",0.0174532925199433],ID["EPSG",8821]],PARAMETER["Longitude of false origin",-96,ANGLEUNIT["degree",0.0174532925199433],ID["EPSG",8822]],PARAMETER["Latitude of 1st standard parallel",29.5,ANGLEUNIT["degree",0.0174532925199433],ID["EPSG",8823]],PARAMETER["Latitude of 2nd standard parallel",45.5,ANGLEUNIT["degree",0.0174532925199433],ID["EPSG",8824]],PARAMETER["Easting at false origin",0,LENGTHUNIT["metre",1],ID["EPSG",8826]],PARAMETER["Northing at false origin",0,LENGTHUNIT["metre",1],ID["EPSG",8827]]],CS[Cartesian,2],AXIS["(E)",east,ORDER[1],LENGTHUNIT["metre",1,ID["EPSG",9001]]],AXIS["(N)",north,ORDER[2],LENGTHUNIT["metre",1,ID["EPSG",9001]]]]"#;
        // The same with its angles in radians and its false easting in US survey feet,
        // each parameter in its own unit as WKT 2 allows; the point moves with it.
        let radians = |degrees: f64| format!("{},ANGLEUNIT[\"radian\",1]", degrees.to_radians());
        let wkt2_radians = wkt2
            .replace(
                r#"23,ANGLEUNIT["degree",0.0174532925199433]"#,
                &radians(23.0),
            )
            .replace(
                r#"-96,ANGLEUNIT["degree",0.0174532925199433]"#,
                &radians(-96.0),
            )
            .replace(
                r#"29.5,ANGLEUNIT["degree",0.0174532925199433]"#,
                &radians(29.5),
            )
            .replace(
                r#"45.5,ANGLEUNIT["degree",0.0174532925199433]"#,
                &radians(45.5),
            )
            .replace(
                r#"Easting at false origin",0,LENGTHUNIT["metre",1]"#,
                r#"Easting at false origin",1000,LENGTHUNIT["US survey foot",0.304800609601219]"#,
            );
        assert!(!wkt2_radians.contains("29.5"));
        let shifted = of_wkt_citation(&wkt2_radians, None, 1.0).unwrap();
        let ([sx, sy], _) = shifted.axis_scales(1.0e6 + 304.800609601219, 1.5e6);
        assert!(
            (sx - conus[0]).abs() < 1e-9 && (sy - conus[1]).abs() < 1e-9,
            "{sx} {sy} against {conus:?}"
        );
        for wkt in [esri, ogc, wkt2] {
            let ours = scales(of_wkt_citation(wkt, None, 1.0).unwrap());
            assert!(
                (ours[0] - conus[0]).abs() < 1e-9 && (ours[1] - conus[1]).abs() < 1e-9,
                "{ours:?} against {conus:?}"
            );
        }
        // NSIDC's polar grid by ESRI's projection name: EPSG:3413's scales.
        let polar = r#"PROJCS["x",GEOGCS["GCS_WGS_1984"],PROJECTION["Stereographic_North_Pole"],PARAMETER["False_Easting",0.0],PARAMETER["Central_Meridian",-45.0],PARAMETER["Standard_Parallel_1",70.0],UNIT["Meter",1.0]]"#;
        let ([ours, _], _) = of_wkt_citation(polar, None, 1.0)
            .unwrap()
            .axis_scales(0.0, -2.0e6);
        let epsg = Projection::of_epsg(3413)
            .unwrap()
            .axis_scales(0.0, -2.0e6)
            .0[0];
        assert!((ours - epsg).abs() < 1e-12, "{ours} against {epsg}");
        // A projection not measured (oblique Mercator) gives none.
        assert!(
            of_wkt_citation(
                r#"PROJCS["x",PROJECTION["Hotine_Oblique_Mercator"]]"#,
                None,
                1.0
            )
            .is_none()
        );
    }

    #[test]
    fn user_defined_projections_read_their_parameters_in_the_crs_units() {
        // A one-parallel Lambert cone scaled 0.9996 at 18° N, false origin in US survey
        // feet: at its false origin a projected metre spans 1 / 0.9996 ground metres.
        let feet = 1200.0 / 3937.0;
        let lcc = projection(
            &[(PROJECTED_CRS, 32767), (COORDINATE_TRANSFORMATION, 9)],
            &[
                (NATURAL_ORIGIN_LATITUDE, 18.0),
                (NATURAL_ORIGIN_LONGITUDE, -77.0),
                (SCALE_AT_NATURAL_ORIGIN, 0.9996),
                (FALSE_EASTING, 820_208.0),
                (FALSE_NORTHING, 492_125.0),
            ],
            feet,
        );
        let ([sx, sy], _) = lcc.axis_scales(820_208.0 * feet, 492_125.0 * feet);
        assert!((sx - 1.0 / 0.9996).abs() < 1e-9 && sx == sy, "{sx}");
        // Angles in radians where the GeoKeys say so: Conus Albers's parameters give
        // EPSG:5070's scales.
        let albers = projection(
            &[
                (COORDINATE_TRANSFORMATION, 11),
                (GEOG_ANGULAR_UNITS, ANGULAR_RADIAN),
            ],
            &[
                (STANDARD_PARALLEL_1, 29.5f64.to_radians()),
                (STANDARD_PARALLEL_2, 45.5f64.to_radians()),
                (FALSE_ORIGIN_LATITUDE, 23f64.to_radians()),
                (FALSE_ORIGIN_LONGITUDE, -96f64.to_radians()),
            ],
            1.0,
        );
        let conus = Projection::of_epsg(5070).unwrap();
        let (ours, epsg) = (
            albers.axis_scales(1.0e6, 1.5e6),
            conus.axis_scales(1.0e6, 1.5e6),
        );
        assert!(
            (ours.0[0] - epsg.0[0]).abs() < 1e-10 && (ours.0[1] - epsg.0[1]).abs() < 1e-10,
            "{ours:?} against {epsg:?}"
        );
        // And in grads (0.9° each), as France's NTF (Paris) grids give theirs.
        let grads = projection(
            &[(COORDINATE_TRANSFORMATION, 11), (GEOG_ANGULAR_UNITS, 9105)],
            &[
                (STANDARD_PARALLEL_1, 29.5 / 0.9),
                (STANDARD_PARALLEL_2, 45.5 / 0.9),
                (FALSE_ORIGIN_LATITUDE, 23.0 / 0.9),
                (FALSE_ORIGIN_LONGITUDE, -96.0 / 0.9),
            ],
            1.0,
        );
        let in_grads = grads.axis_scales(1.0e6, 1.5e6);
        assert!((in_grads.0[0] - epsg.0[0]).abs() < 1e-10, "{in_grads:?}");
        // Transverse Mercator (CT 1) with its false easting in feet: 1000 km east of
        // its meridian a projected metre spans 0.9882 ground metres.
        let tm = projection(
            &[(COORDINATE_TRANSFORMATION, 1)],
            &[
                (SCALE_AT_NATURAL_ORIGIN, 0.9996),
                (FALSE_EASTING, 500_000.0 / feet),
            ],
            feet,
        );
        let ([sx, _], _) = tm.axis_scales(1.5e6, 0.0);
        assert!((sx - 0.988_219_404_8).abs() < 1e-4, "{sx}");
        // A transformation with no reader here (the New Zealand Map Grid, CT 26) is
        // not measured.
        let short_key = |id: u16| (id == COORDINATE_TRANSFORMATION).then_some(26);
        let keys = GeoKeys {
            short: &short_key,
            double: &|_| None,
            citations: "",
        };
        assert!(of_keys(&keys, 1.0).is_none());
    }

    #[test]
    fn proj_strings_measure_as_the_registry_measures_them() {
        // Every registry CRS whose PROJ string becomes a user-defined WKT (a projection
        // read from PROJ strings, not a named UTM zone): the WKT's projection has the
        // registry's scales about its false origin.
        let mut compared = 0;
        for code in 1..=u16::MAX {
            let Some(crs) = crate::grid::epsg_crs(code) else {
                continue;
            };
            let (Some(registry), Some(unit)) = (crs.projection(), crs.metres_per_unit()) else {
                continue;
            };
            let proj = crs_definitions::from_code(code).unwrap().proj4;
            let Ok((_, citation)) = crate::io::proj_string::proj_string_geokeys(proj) else {
                continue;
            };
            // Guam's azimuthal equidistant (`+guam`) is a variant no WKT method names.
            if citation.is_empty() || crs.has("guam") {
                continue;
            }
            // Projections with no formula here are measured through PROJ's inverse
            // where the WKT's method is one it carries (not the oblique Mercators).
            let Some(ours) = of_wkt_citation(&citation, None, unit).or_else(|| {
                assert!(registry.is_numeric(), "EPSG:{code} {proj}: {citation}");
                None
            }) else {
                continue;
            };
            let origin = [crs.number("x_0"), crs.number("y_0")].map(|v| v.unwrap_or(0.0));
            for (dx, dy) in [(0.0, 0.0), (1.0e5, 2.0e5), (-2.0e5, -1.0e5)] {
                let (x, y) = (origin[0] + dx, origin[1] + dy);
                let (a, b) = (ours.axis_scales(x, y).0, registry.axis_scales(x, y).0);
                for (a, b) in a.into_iter().zip(b) {
                    let agree =
                        a == b || (a - b).abs() <= 1e-6 * a.abs() || (a.is_nan() && b.is_nan());
                    assert!(agree, "EPSG:{code} {proj} at ({x}, {y}): {a} against {b}");
                }
            }
            compared += 1;
        }
        assert!(compared > 1000, "{compared}");
    }
}
