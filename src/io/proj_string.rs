//! CRSs given as PROJ strings (`+proj=sterea +lat_0=52.156 ... +units=m`), as R's
//! `raster` package writes them in its `.grd` headers: the GeoKeys GDAL would write for
//! them. An EPSG code (`+init=epsg:28992`), or longitude and latitude or a UTM zone on
//! a datum `named_crs` knows, become that EPSG CRS; any other projection of the table
//! below becomes a user-defined CRS in ESRI's WKT 1, which the GeoTIFF reader measures
//! as it measures a GeoTIFF's (`geotiff::projection::of_wkt_citation`).

use super::geotiff::wkt_geokeys;
use super::named_crs::{self, Named};
use crate::grid::{ProjCrs, epsg_crs};

/// A CRS's GeoKeys and the citations they point into.
pub(crate) type CrsKeys = (Vec<u16>, String);

/// The PROJ projections read, by PROJ's name.
const READ: &str = "longlat, utm, tmerc, etmerc, lcc, stere, sterea, merc, aea, laea, cea, \
                    sinu, moll, eqearth, somerc, omerc, cass, aeqd";

/// The GeoKeys of the CRS PROJ string `proj` gives; an error says what cannot be read.
pub(crate) fn proj_string_geokeys(proj: &str) -> Result<CrsKeys, String> {
    let crs = ProjCrs::parse(proj);
    if let Some(code) = crs.value("init").and_then(|init| {
        init.to_ascii_lowercase()
            .strip_prefix("epsg:")?
            .parse()
            .ok()
    }) && let Some(registered) = epsg_crs(code)
    {
        let keys = named_crs::epsg_geokeys(code, !registered.is_geographic());
        return Ok((keys, String::new()));
    }
    let datum = crs
        .value("datum")
        .or_else(|| matches!(crs.value("ellps"), Some("WGS84" | "GRS80")).then_some("WGS84"));
    let named = match crs.projection_name() {
        "longlat" | "latlong" | "lonlat" | "latlon" => Some(Named::Geographic),
        "utm" => {
            let zone = crs.number("zone").filter(|z| (1.0..=60.0).contains(z));
            let zone = zone.ok_or_else(|| format!("its UTM zone in '{proj}' is not 1 to 60"))?;
            Some(Named::Utm {
                zone: zone as u16,
                north: !crs.has("south"),
            })
        }
        _ => None,
    };
    if let Some(keys) = named
        .zip(datum)
        .and_then(|(named, datum)| named_crs::geokeys(named, datum))
    {
        return Ok((keys, String::new()));
    }
    let wkt = esri_wkt_of(&crs).ok_or_else(|| {
        format!(
            "its projection '{proj}' is not one read from a PROJ string ({READ}): write \
             the CRS beside it as a .prj"
        )
    })?;
    wkt_geokeys(&wkt).ok_or_else(|| format!("its projection '{proj}' cannot be read"))
}

/// The GeoKeys of a CRS as GDAL takes one from a user (a VRT's `<SRS>`, which GDAL
/// parses with `SetFromUserInput`): WKT, a PROJ string, or an EPSG code as `EPSG:n`,
/// an OGC URN or an OGC URL; an error says what cannot be read.
pub(crate) fn user_crs_geokeys(text: &str) -> Result<CrsKeys, String> {
    let text = text.trim();
    if text.starts_with('+') {
        return proj_string_geokeys(text);
    }
    let lower = text.to_ascii_lowercase();
    let code = ["epsg:", "urn:ogc:def:crs:epsg::", "urn:ogc:def:crs:epsg:"]
        .iter()
        .chain(&["http://www.opengis.net/def/crs/epsg/0/"])
        .find_map(|prefix| lower.strip_prefix(prefix));
    if let Some(code) = code {
        let number = code.trim().parse::<u16>().ok();
        let registered = number.and_then(|n| epsg_crs(n).map(|crs| (n, crs)));
        let (number, crs) =
            registered.ok_or_else(|| format!("its CRS '{text}' is not an EPSG code we know"))?;
        return Ok((
            named_crs::epsg_geokeys(number, !crs.is_geographic()),
            String::new(),
        ));
    }
    wkt_geokeys(text).ok_or_else(|| {
        format!("its CRS is neither WKT of a projected or geographic CRS, a PROJ string nor an EPSG code: {text}")
    })
}

/// ESRI's WKT 1 of a PROJ CRS whose projection is one of [`READ`].
fn esri_wkt_of(crs: &ProjCrs) -> Option<String> {
    let number = |key: &str| crs.number(key);
    let or_zero = |key: &str| number(key).unwrap_or(0.0);
    let scale = number("k").or(number("k_0")).unwrap_or(1.0);
    let (lat_0, lon_0) = (or_zero("lat_0"), or_zero("lon_0"));
    let axes = crs.axes();
    let geographic = matches!(
        crs.projection_name(),
        "longlat" | "latlong" | "lonlat" | "latlon"
    );
    if geographic {
        return Some(esri_geographic_wkt("PROJ", axes));
    }
    let unit = crs.metres_per_unit()?;
    let mut false_origin = [or_zero("x_0") / unit, or_zero("y_0") / unit];
    let origin_scale = || {
        vec![
            ("Central_Meridian", lon_0),
            ("Scale_Factor", scale),
            ("Latitude_Of_Origin", lat_0),
        ]
    };
    let (projection, parameters): (&str, Vec<(&str, f64)>) = match crs.projection_name() {
        "tmerc" | "etmerc" => ("Transverse_Mercator", origin_scale()),
        "utm" => {
            let zone = number("zone").filter(|z| (1.0..=60.0).contains(z))?.trunc();
            false_origin = [
                500_000.0 / unit,
                if crs.has("south") { 1e7 / unit } else { 0.0 },
            ];
            (
                "Transverse_Mercator",
                vec![
                    ("Central_Meridian", 6.0 * zone - 183.0),
                    ("Scale_Factor", 0.9996),
                    ("Latitude_Of_Origin", 0.0),
                ],
            )
        }
        "lcc" => {
            let first = number("lat_1")?;
            (
                "Lambert_Conformal_Conic",
                vec![
                    ("Standard_Parallel_1", first),
                    ("Standard_Parallel_2", number("lat_2").unwrap_or(first)),
                    ("Central_Meridian", lon_0),
                    ("Scale_Factor", scale),
                    ("Latitude_Of_Origin", number("lat_0").unwrap_or(first)),
                ],
            )
        }
        "stere" if (lat_0.abs() - 90.0).abs() < 1e-9 => {
            match number("lat_ts").filter(|t| (t.abs() - 90.0).abs() > 1e-9) {
                // True to scale on a parallel (EPSG's variant B)...
                Some(true_scale) => (
                    if lat_0 < 0.0 {
                        "Stereographic_South_Pole"
                    } else {
                        "Stereographic_North_Pole"
                    },
                    vec![
                        ("Central_Meridian", lon_0),
                        ("Standard_Parallel_1", true_scale),
                    ],
                ),
                // ...or scaled at the pole (variant A, UPS).
                None => ("Polar_Stereographic_Variant_A", origin_scale()),
            }
        }
        "stere" => ("Stereographic", origin_scale()),
        "sterea" => ("Double_Stereographic", origin_scale()),
        "merc" => {
            // ESRI's Mercator is true to scale on a parallel; a scale k0 on the
            // equator is the parallel whose m(φ) = cos φ / √(1 − e² sin² φ) is k0:
            // sin² φ = (1 − k0²) / (1 − e² k0²).
            let true_scale = number("lat_ts").unwrap_or_else(|| {
                let (_, rf) = axes;
                let e2 = if rf > 0.0 { (2.0 - 1.0 / rf) / rf } else { 0.0 };
                let k2 = scale.clamp(0.0, 1.0).powi(2);
                ((1.0 - k2) / (1.0 - e2 * k2)).sqrt().asin().to_degrees()
            });
            (
                "Mercator",
                vec![
                    ("Central_Meridian", lon_0),
                    ("Standard_Parallel_1", true_scale),
                ],
            )
        }
        "aea" => {
            let first = number("lat_1")?;
            (
                "Albers",
                vec![
                    ("Central_Meridian", lon_0),
                    ("Standard_Parallel_1", first),
                    ("Standard_Parallel_2", number("lat_2").unwrap_or(first)),
                    ("Latitude_Of_Origin", lat_0),
                ],
            )
        }
        "laea" => (
            "Lambert_Azimuthal_Equal_Area",
            vec![("Central_Meridian", lon_0), ("Latitude_Of_Origin", lat_0)],
        ),
        "cea" => (
            "Cylindrical_Equal_Area",
            vec![
                ("Central_Meridian", lon_0),
                ("Standard_Parallel_1", or_zero("lat_ts")),
            ],
        ),
        "sinu" => ("Sinusoidal", vec![("Central_Meridian", lon_0)]),
        "moll" => ("Mollweide", vec![("Central_Meridian", lon_0)]),
        "eqearth" => ("Equal_Earth", vec![("Central_Meridian", lon_0)]),
        "somerc" | "omerc" => (
            "Hotine_Oblique_Mercator_Azimuth_Center",
            vec![
                ("Scale_Factor", scale),
                ("Azimuth", number("alpha").unwrap_or(90.0)),
                ("Longitude_Of_Center", number("lonc").unwrap_or(lon_0)),
                ("Latitude_Of_Center", lat_0),
            ],
        ),
        "cass" => ("Cassini", origin_scale()),
        "aeqd" => (
            "Azimuthal_Equidistant",
            vec![("Central_Meridian", lon_0), ("Latitude_Of_Origin", lat_0)],
        ),
        _ => return None,
    };
    Some(esri_projected_wkt(
        "PROJ",
        axes,
        projection,
        false_origin,
        &parameters,
        unit,
    ))
}

/// ESRI's WKT 1 of a geographic CRS in degrees on the ellipsoid of semi-major axis and
/// inverse flattening `axes` (0: a sphere), named `name`.
fn esri_geographic_wkt(name: &str, (a, rf): (f64, f64)) -> String {
    format!(
        "GEOGCS[\"GCS_{name}\",DATUM[\"D_{name}\",SPHEROID[\"S_{name}\",{a},{rf}]],\
         PRIMEM[\"Greenwich\",0.0],UNIT[\"Degree\",0.0174532925199433]]"
    )
}

/// ESRI's WKT 1 of a projected CRS named `name` (the form an Imagine file's PE string
/// takes): `projection` with its false easting and northing (in the CRS's unit) and
/// `parameters` (angles in degrees) on the ellipsoid `axes`, coordinates in units of
/// `metres_per_unit` metres.
pub(crate) fn esri_projected_wkt(
    name: &str,
    axes: (f64, f64),
    projection: &str,
    [false_easting, false_northing]: [f64; 2],
    parameters: &[(&str, f64)],
    metres_per_unit: f64,
) -> String {
    let mut wkt = format!(
        "PROJCS[\"{name}\",{},PROJECTION[\"{projection}\"],\
         PARAMETER[\"False_Easting\",{false_easting}],PARAMETER[\"False_Northing\",{false_northing}]",
        esri_geographic_wkt(name, axes)
    );
    for (parameter, value) in parameters {
        wkt.push_str(&format!(",PARAMETER[\"{parameter}\",{value}]"));
    }
    let unit = if metres_per_unit == 1.0 {
        "Meter"
    } else {
        "Unit"
    };
    wkt.push_str(&format!(",UNIT[\"{unit}\",{metres_per_unit}]]"));
    wkt
}

#[cfg(test)]
mod tests {
    use super::*;

    fn code(proj: &str) -> Option<u16> {
        let (keys, citation) = proj_string_geokeys(proj).unwrap();
        citation.is_empty().then(|| keys[11])
    }

    #[test]
    fn named_and_registered_crss_become_their_epsg_codes() {
        assert_eq!(code("+proj=longlat +datum=WGS84 +no_defs"), Some(4326));
        assert_eq!(
            code("+proj=utm +zone=56 +south +ellps=WGS84 +units=m"),
            Some(32756)
        );
        assert_eq!(code("+proj=utm +zone=17 +datum=NAD27"), Some(26717));
        assert_eq!(
            code("+init=epsg:28992 +proj=sterea +lat_0=52.15616055555555"),
            Some(28992)
        );
    }

    #[test]
    fn other_projections_become_user_defined_wkt() {
        // The Dutch RD grid as R's raster package writes it (its own example file).
        let (keys, citation) = proj_string_geokeys(
            "+proj=sterea +lat_0=52.1561605555556 +lon_0=5.38763888888889 +k=0.9999079 \
             +x_0=155000 +y_0=463000 +datum=WGS84 +units=m +no_defs",
        )
        .unwrap();
        assert!(
            citation.contains("PROJECTION[\"Double_Stereographic\"]"),
            "{citation}"
        );
        assert!(citation.contains("PARAMETER[\"False_Northing\",463000]"));
        assert!(citation.contains("PARAMETER[\"Scale_Factor\",0.9999079]"));
        assert!(keys.contains(&32767));
        // UTM on another ellipsoid, in feet: the zone's meridian, false origin in feet.
        let (_, citation) =
            proj_string_geokeys("+proj=utm +zone=33 +ellps=intl +units=ft").unwrap();
        assert!(
            citation.contains("PARAMETER[\"Central_Meridian\",15]"),
            "{citation}"
        );
        assert!(citation.contains("SPHEROID[\"S_PROJ\",6378388,297]"));
        assert!(citation.contains(&format!("False_Easting\",{}]", 500_000.0 / 0.3048)));
        assert!(citation.ends_with("UNIT[\"Unit\",0.3048]]|"), "{citation}");
        // A sphere of radius R; a polar grid scaled at the pole.
        let (_, citation) = proj_string_geokeys("+proj=laea +lat_0=90 +R=6371228").unwrap();
        assert!(citation.contains("SPHEROID[\"S_PROJ\",6371228,0]"));
        let (_, citation) =
            proj_string_geokeys("+proj=stere +lat_0=-90 +k=0.994 +datum=WGS84").unwrap();
        assert!(
            citation.contains("Polar_Stereographic_Variant_A"),
            "{citation}"
        );
    }

    #[test]
    fn users_give_crss_in_wkt_proj_strings_or_epsg_codes() {
        let code = |text: &str| user_crs_geokeys(text).unwrap().0[11];
        assert_eq!(code("EPSG:32633"), 32633);
        assert_eq!(code(" urn:ogc:def:crs:EPSG::4326"), 4326);
        assert_eq!(code("http://www.opengis.net/def/crs/EPSG/0/3857"), 3857);
        assert_eq!(
            code("+proj=utm +zone=18 +datum=WGS84 +towgs84=0,0,0"),
            32618
        );
        assert_eq!(
            code(
                r#"GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],AUTHORITY["EPSG","4326"]]"#
            ),
            4326
        );
        assert!(user_crs_geokeys("EPSG:1").unwrap_err().contains("EPSG:1"));
        assert!(user_crs_geokeys("WGS84").unwrap_err().contains("WGS84"));
    }

    #[test]
    fn what_cannot_be_read_is_named() {
        for proj in [
            "+proj=robin +datum=WGS84",
            "+proj=utm +zone=61",
            "+units=m",
            "",
        ] {
            let error = proj_string_geokeys(proj).unwrap_err();
            assert!(error.contains(proj.trim()), "{error}");
        }
        assert!(proj_string_geokeys("+proj=geocent +datum=WGS84").is_err());
        assert!(proj_string_geokeys("+proj=lcc +lon_0=3").is_err());
    }
}
