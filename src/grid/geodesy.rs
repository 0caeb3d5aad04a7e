//! Lengths of a degree on the WGS 84 ellipsoid, so that rasters in geographic
//! coordinates (EPSG:4326 and its kin) are measured in metres, of a Web Mercator
//! metre (EPSG:3857), which is a ground metre only on the equator, and of a metre of
//! the conformal projections whose scale is far from 1 where rasters lie (polar
//! stereographic, World Mercator, Lambert conformal conic) and of the equal-area ones
//! (`equal_area`).

use super::equal_area::{Ellipsoid, EqualArea};
use super::world_sphere::WorldSphere;

/// WGS 84 semi-major axis (m) and first eccentricity squared.
const A: f64 = Ellipsoid::WGS84.a;
const E2: f64 = Ellipsoid::WGS84.e2;

/// Metres per degree of longitude (east) and of latitude (north) at `latitude` degrees:
/// the parallel's radius N·cos φ and the meridian's radius of curvature M, times π/180.
pub fn metres_per_degree(latitude: f64) -> [f64; 2] {
    let phi = latitude.to_radians();
    let w = 1.0 - E2 * phi.sin().powi(2);
    let n = A / w.sqrt();
    let m = A * (1.0 - E2) / (w * w.sqrt());
    let radians = std::f64::consts::PI / 180.0;
    [n * phi.cos() * radians, m * radians]
}

/// Ground metres per Web Mercator (EPSG:3857) unit east and north at projected
/// northing `y`. The projection applies the sphere's formulas (radius `A`) to WGS 84
/// latitudes: φ = atan(sinh(y / A)), and one unit of x or y spans A / cos φ on that
/// sphere; on the ellipsoid a unit east is N(φ)·cos φ / A ground metres and a unit
/// north M(φ)·cos φ / A (the projection is not quite conformal on the ellipsoid).
pub fn metres_per_web_mercator_unit(y: f64) -> [f64; 2] {
    let phi = (y / A).sinh().atan();
    let [east, north] = metres_per_degree(phi.to_degrees());
    // metres_per_degree gives N·cos φ·π/180 and M·π/180 per degree.
    let radians = std::f64::consts::PI / 180.0;
    [east / radians / A, north / radians * phi.cos() / A]
}

/// The latitude (degrees) of Web Mercator northing `y`.
pub fn web_mercator_latitude(y: f64) -> f64 {
    (y / A).sinh().atan().to_degrees()
}

/// WGS 84's first eccentricity.
fn eccentricity() -> f64 {
    E2.sqrt()
}

/// m(φ) = cos φ / √(1 − e² sin² φ): the parallel's radius over A.
fn m(phi: f64) -> f64 {
    phi.cos() / (1.0 - E2 * phi.sin().powi(2)).sqrt()
}

/// t(φ) = tan(π/4 − φ/2) / ((1 − e sin φ) / (1 + e sin φ))^(e/2) (Snyder's 15-9).
fn t(phi: f64) -> f64 {
    let e = eccentricity();
    let s = e * phi.sin();
    (std::f64::consts::FRAC_PI_4 - phi / 2.0).tan() / ((1.0 - s) / (1.0 + s)).powf(e / 2.0)
}

/// The latitude whose t is `t`, by fixed-point iteration (7-9; converges to 1e-15 in a
/// few steps).
fn latitude_of_t(t: f64) -> f64 {
    let e = eccentricity();
    let mut phi = std::f64::consts::FRAC_PI_2 - 2.0 * t.atan();
    for _ in 0..20 {
        let s = e * phi.sin();
        phi =
            std::f64::consts::FRAC_PI_2 - 2.0 * (t * ((1.0 - s) / (1.0 + s)).powf(e / 2.0)).atan();
    }
    phi
}

/// How far from 1 a projection's scale is read as 1: a grid metre within 0.1 % of a
/// ground metre (UTM inside its zone, a State Plane grid) is read as one, as gdalinfo's
/// cell size is.
pub const TRUE_SCALE_TOLERANCE: f64 = 1e-3;

/// A conformal projection on WGS 84 whose point scale the reader corrects for.
enum Conformal {
    /// Mercator on WGS 84, or on a sphere of the radius given, scaled `k0` on the
    /// equator (1: World Mercator, EPSG:3395; m(φ) of its latitude of true scale
    /// otherwise), the equator at the false northing.
    Mercator {
        k0: f64,
        false_northing: f64,
        sphere: Option<f64>,
    },
    /// Polar stereographic about either pole (its scale depends only on the distance
    /// from it), true to scale on a latitude (variant B, NSIDC's and the Antarctic
    /// grids) or scaled by k0 at the pole (variant A, UPS), from a false origin.
    PolarStereographic {
        scale: PolarScale,
        false_origin: [f64; 2],
    },
    /// Lambert conformal conic (Snyder §15): parallels lie at ρ = A·K·t(φ)ⁿ from the
    /// cone's apex, which lies ρ0 north of the false origin.
    LambertConic {
        n: f64,
        k: f64,
        rho0: f64,
        false_origin: [f64; 2],
    },
    /// Transverse Mercator (UTM and the national grids), scaled `k0` on its central
    /// meridian, which lies at the false easting.
    TransverseMercator { k0: f64, false_easting: f64 },
}

/// How a polar stereographic projection is scaled: true on a latitude (degrees), or
/// by k0 at the pole.
pub(super) enum PolarScale {
    TrueLatitude(f64),
    AtPole(f64),
}

impl Conformal {
    /// The projections known by their EPSG code.
    fn of(code: u16) -> Option<Conformal> {
        use PolarScale::*;
        let polar = |scale, false_origin| Conformal::PolarStereographic {
            scale,
            false_origin,
        };
        let lambert = Conformal::lambert_conic;
        Some(match code {
            3395 => Conformal::Mercator {
                k0: 1.0,
                false_northing: 0.0,
                sphere: None,
            },
            3413 => polar(TrueLatitude(70.0), [0.0; 2]), // NSIDC Sea Ice Polar Stereographic North
            3995 => polar(TrueLatitude(71.0), [0.0; 2]), // Arctic Polar Stereographic
            3031 => polar(TrueLatitude(71.0), [0.0; 2]), // Antarctic Polar Stereographic
            3976 => polar(TrueLatitude(70.0), [0.0; 2]), // NSIDC Sea Ice Polar Stereographic South
            32661 | 5041 => polar(AtPole(0.994), [2.0e6; 2]), // UPS North
            32761 | 5042 => polar(AtPole(0.994), [2.0e6; 2]), // UPS South
            2154 => lambert([49.0, 44.0], 1.0, 46.5, [700_000.0, 6_600_000.0]), // Lambert-93
            3034 => lambert([35.0, 65.0], 1.0, 52.0, [4.0e6, 2.8e6]), // LCC Europe
            3978 | 3979 => lambert([49.0, 77.0], 1.0, 49.0, [0.0; 2]), // Canada Atlas Lambert
            3347 => lambert([49.0, 77.0], 1.0, 63.390_675, [6.2e6, 3.0e6]), // Statistics Canada
            3112 => lambert([-18.0, -36.0], 1.0, 0.0, [0.0; 2]), // Geoscience Australia
            _ => return Conformal::transverse_mercator_of(code),
        })
    }

    /// The Transverse Mercator grids known by their EPSG code: UTM on WGS 84, ETRS89,
    /// NAD83 (and its 2011 realisation), NAD27, GDA94 and GDA2020 (MGA), and the
    /// national grids of Britain, New Zealand, Finland, Sweden, Greece and Germany's
    /// Gauss–Krüger zones.
    fn transverse_mercator_of(code: u16) -> Option<Conformal> {
        let utm = |k0, false_easting| Conformal::TransverseMercator { k0, false_easting };
        Some(match code {
            32601..=32660
            | 32701..=32760
            | 25828..=25838
            | 26901..=26923
            | 6328..=6348
            | 26701..=26722
            | 28348..=28358
            | 7846..=7859
            | 3067
            | 3006
            | 2100 => utm(0.9996, 500_000.0),
            27700 => utm(0.999_601_271_7, 400_000.0), // British National Grid
            2193 => utm(0.9996, 1_600_000.0),         // New Zealand TM
            31466..=31469 => utm(1.0, f64::from(code - 31464) * 1.0e6 + 500_000.0), // DHDN GK
            _ => return None,
        })
    }

    /// Lambert conformal conic true to scale on two standard parallels (degrees; give
    /// the same one twice and its scale `k0` for the one-parallel variant), with the
    /// false origin's latitude and its easting and northing.
    fn lambert_conic(
        parallels: [f64; 2],
        k0: f64,
        origin_latitude: f64,
        false_origin: [f64; 2],
    ) -> Conformal {
        let [phi1, phi2] = parallels.map(f64::to_radians);
        // One parallel: the limit of (15-8) is sin φ1.
        let n = if (phi1 - phi2).abs() < 1e-12 {
            phi1.sin()
        } else {
            (m(phi1).ln() - m(phi2).ln()) / (t(phi1).ln() - t(phi2).ln())
        };
        let k = k0 * m(phi1) / (n * t(phi1).powf(n));
        let rho0 = A * k * t(origin_latitude.to_radians()).powf(n);
        Conformal::LambertConic {
            n,
            k,
            rho0,
            false_origin,
        }
    }

    /// Ground metres per projected metre at (x, y): 1 / the point scale factor.
    fn ground_per_unit(&self, x: f64, y: f64) -> f64 {
        let e = eccentricity();
        match self {
            Conformal::Mercator {
                k0,
                false_northing,
                sphere,
            } => match sphere {
                // y = A·k0·ln(1/t(φ)), and k = k0 / m(φ)...
                None => {
                    let y = (y - false_northing).abs() / (A * k0);
                    m(latitude_of_t((-y).exp())) / k0
                }
                // ...on a sphere, y = R·k0·asinh(tan φ), and k = k0 / cos φ.
                Some(radius) => ((y - false_northing) / (radius * k0)).sinh().atan().cos() / k0,
            },
            Conformal::PolarStereographic {
                scale,
                false_origin,
                ..
            } => {
                let rho = (x - false_origin[0]).hypot(y - false_origin[1]);
                // ρ = A·c·t(φ): c from the scale's definition.
                let c = match *scale {
                    PolarScale::TrueLatitude(lat) => {
                        let phi = lat.abs().to_radians();
                        m(phi) / t(phi)
                    }
                    PolarScale::AtPole(k0) => {
                        2.0 * k0 / ((1.0 + e).powf(1.0 + e) * (1.0 - e).powf(1.0 - e)).sqrt()
                    }
                };
                // k = ρ / (A·m(φ)) = c·t(φ)/m(φ); at the pole t/m tends to
                // √((1+e)^(1+e)(1−e)^(1−e)) / 2.
                let k = if rho < 1e-6 {
                    c * ((1.0 + e).powf(1.0 + e) * (1.0 - e).powf(1.0 - e)).sqrt() / 2.0
                } else {
                    let phi = latitude_of_t(rho / (A * c));
                    c * t(phi) / m(phi)
                };
                1.0 / k
            }
            Conformal::LambertConic {
                n,
                k,
                rho0,
                false_origin,
            } => {
                // (15-10), (15-11): ρ takes the sign of n; then k = ρn / (A·m(φ)).
                let (x, y) = (x - false_origin[0], y - false_origin[1]);
                let rho = n.signum() * x.hypot(rho0 - y);
                let phi = latitude_of_t((rho / (A * k)).powf(1.0 / n));
                A * m(phi) / (rho * n)
            }
            Conformal::TransverseMercator { k0, false_easting } => {
                // The sphere's k = k0·cosh(x / (k0·A)): within 1e-4 of PROJ's ellipsoidal
                // scale 2000 km from the meridian. Within 0.1 % of true scale (UTM
                // inside its zone) a grid metre is read as a ground metre, as gdalinfo's
                // cell size is.
                let k = k0 * ((x - false_easting) / (k0 * A)).cosh();
                if (k - 1.0).abs() <= TRUE_SCALE_TOLERANCE {
                    1.0
                } else {
                    1.0 / k
                }
            }
        }
    }
}

/// A projected CRS whose metre is not a ground metre where rasters lie, which the
/// reader measures: the conformal projections far from true scale (polar
/// stereographic: NSIDC's 3413 and 3976, 3995, 3031, UPS; World Mercator, 3395;
/// Lambert conformal conic: LCC Europe 3034, Canada's 3978 and 3347, Australia's
/// 3112, Lambert-93), whose scale is one number at a point, and the equal-area ones
/// (Albers, LAEA), whose scale differs along x and y. Transverse Mercator (UTM and the
/// national grids) is measured where a raster lies more than 0.1 % from true scale:
/// far outside its zone.
pub struct Projection(Kind);

enum Kind {
    Conformal(Conformal),
    EqualArea(EqualArea),
    Numeric(Box<Numeric>),
}

/// A projection measured through an inverse: PROJ's (`proj4rs`) for the projections
/// with no formula here (equidistant cylindrical and conic, azimuthal equidistant,
/// oblique and equatorial stereographic, orthographic, gnomonic, Robinson, Miller,
/// polyconic, Cassini, Krovak...), and the world maps on a sphere that `proj4rs` lacks
/// ([`WorldSphere`]: Eckert IV, Van der Grinten, Winkel Tripel...). Steps of a metre
/// along x and y are carried back to longitude and latitude on the projection's own
/// ellipsoid (no datum shift) and measured there.
struct Numeric {
    inverse: Inverse,
    ellipsoid: Ellipsoid,
}

/// Where a [`Numeric`] projection's inverse comes from.
enum Inverse {
    Proj {
        projection: Box<proj4rs::proj::Proj>,
        geographic: Box<proj4rs::proj::Proj>,
    },
    World(WorldSphere),
}

impl Numeric {
    /// From a PROJ string whose coordinates are metres; `None` where neither `proj4rs`
    /// nor [`WorldSphere`] carries it, or carries it to nowhere near where it came from.
    fn of(definition: &str) -> Option<Numeric> {
        // The definition's ellipsoid: `proj4rs` gives spherical methods (equidistant
        // cylindrical, Robinson) a sphere, yet their latitudes are PROJ's geodetic ones.
        let ellipsoid = super::epsg::ProjCrs::parse(definition).ellipsoid();
        let Ok(projection) = proj4rs::proj::Proj::from_proj_string(definition) else {
            return WorldSphere::of(definition).map(|world| Numeric {
                inverse: Inverse::World(world),
                ellipsoid,
            });
        };
        if projection.is_latlong() {
            return None;
        }
        let (a, b) = (ellipsoid.a, ellipsoid.a * (1.0 - ellipsoid.e2).sqrt());
        let geographic =
            proj4rs::proj::Proj::from_proj_string(&format!("+proj=longlat +a={a} +b={b}")).ok()?;
        Some(Numeric {
            inverse: Inverse::Proj {
                projection: Box::new(projection),
                geographic: Box::new(geographic),
            },
            ellipsoid,
        })
    }

    /// Longitude and latitude (radians) of projected (x, y), checked by carrying them
    /// back to within a millimetre.
    fn geographic_of(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        use proj4rs::transform::transform;
        let (projection, geographic) = match &self.inverse {
            Inverse::Proj {
                projection,
                geographic,
            } => (projection, geographic),
            Inverse::World(world) => return world.inverse(x, y),
        };
        let mut point = (x, y, 0.0);
        transform(projection, geographic, &mut point).ok()?;
        let (lon, lat) = (point.0, point.1);
        let mut back = (lon, lat, 0.0);
        transform(geographic, projection, &mut back).ok()?;
        let close = (back.0 - x).abs() < 1e-3 && (back.1 - y).abs() < 1e-3;
        (close && lon.is_finite() && lat.is_finite()).then_some((lon, lat))
    }

    /// Ground metres per projected metre along x and y at (x, y), and the cosine of the
    /// angle between the axes on the ground; NaN outside the projection's domain.
    fn axis_scales(&self, x: f64, y: f64) -> ([f64; 2], f64) {
        let step = 1.0;
        let (Some(here), Some(east), Some(north)) = (
            self.geographic_of(x, y),
            self.geographic_of(x + step, y),
            self.geographic_of(x, y + step),
        ) else {
            return ([f64::NAN; 2], 0.0);
        };
        // Metres per radian along the parallel (N·cos φ) and the meridian (M).
        let Ellipsoid { a, e2 } = self.ellipsoid;
        let w = 1.0 - e2 * here.1.sin().powi(2);
        let (per_lon, per_lat) = (a / w.sqrt() * here.1.cos(), a * (1.0 - e2) / (w * w.sqrt()));
        // A step's ground vector: east by the longitude's change on the parallel,
        // north by the latitude's on the meridian.
        let ground = |(lon, lat): (f64, f64)| {
            let dlon = (lon - here.0 + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            [dlon * per_lon, (lat - here.1) * per_lat]
        };
        let (u, v) = (ground(east), ground(north));
        let (lu, lv) = (u[0].hypot(u[1]), v[0].hypot(v[1]));
        (
            [lu / step, lv / step],
            (u[0] * v[0] + u[1] * v[1]) / (lu * lv),
        )
    }
}

impl Projection {
    /// The projection of `EPSG:<code>`, where it is one of these: listed by hand (with
    /// codes newer than the registry), else from the EPSG registry's parameters.
    pub fn of_epsg(code: u16) -> Option<Projection> {
        Projection::of_epsg_listed(code)
            .or_else(|| super::epsg::epsg_crs(code).and_then(|crs| crs.projection()))
    }

    /// The projections listed here by their EPSG code.
    pub(super) fn of_epsg_listed(code: u16) -> Option<Projection> {
        Conformal::of(code)
            .map(Kind::Conformal)
            .or_else(|| EqualArea::of_epsg(code).map(Kind::EqualArea))
            .map(Projection)
    }

    /// Polar stereographic on WGS 84 about either pole, from its false origin (metres).
    pub(super) fn polar_stereographic(scale: PolarScale, false_origin: [f64; 2]) -> Projection {
        Projection(Kind::Conformal(Conformal::PolarStereographic {
            scale,
            false_origin,
        }))
    }

    /// Polar stereographic on WGS 84 true to scale on a latitude (degrees from the
    /// equator, either hemisphere), from its false origin (metres).
    pub fn polar_stereographic_true_at(latitude: f64, false_origin: [f64; 2]) -> Projection {
        Projection::polar_stereographic(PolarScale::TrueLatitude(latitude), false_origin)
    }

    /// Polar stereographic on WGS 84 about either pole with scale `k0` at the pole
    /// (EPSG's variant A), from its false origin (metres).
    pub fn polar_stereographic_scaled_at_pole(k0: f64, false_origin: [f64; 2]) -> Projection {
        Projection::polar_stereographic(PolarScale::AtPole(k0), false_origin)
    }

    /// Mercator true to scale on a latitude (degrees; 0 for World Mercator, EPSG:3395)
    /// of `ellipsoid`, or on the equator scaled by `k0` where no latitude is given; the
    /// equator at the false northing (metres). Measured on WGS 84 from there, or on
    /// the sphere where `ellipsoid` is one.
    pub fn mercator(
        ellipsoid: Ellipsoid,
        true_latitude: Option<f64>,
        k0: f64,
        false_northing: f64,
    ) -> Projection {
        let k0 = true_latitude.map_or(k0, |latitude| ellipsoid.m(latitude.to_radians()));
        let sphere = (ellipsoid.e2 == 0.0).then_some(ellipsoid.a);
        Projection(Kind::Conformal(Conformal::Mercator {
            k0,
            false_northing,
            sphere,
        }))
    }

    /// An equal-area projection the GeoKeys define by its parameters.
    pub fn equal_area(projection: EqualArea) -> Projection {
        Projection(Kind::EqualArea(projection))
    }

    /// A Transverse Mercator projection the GeoKeys define by its parameters: its scale
    /// on the central meridian and its false easting (metres).
    pub fn transverse_mercator(k0: f64, false_easting: f64) -> Projection {
        Projection(Kind::Conformal(Conformal::TransverseMercator {
            k0,
            false_easting,
        }))
    }

    /// A Lambert conformal conic projection the GeoKeys define by its parameters:
    /// two standard parallels (degrees), or one given twice with its scale `k0`; the
    /// false origin's latitude, easting and northing.
    pub fn lambert_conformal(
        parallels: [f64; 2],
        k0: f64,
        origin_latitude: f64,
        false_origin: [f64; 2],
    ) -> Projection {
        Projection(Kind::Conformal(Conformal::lambert_conic(
            parallels,
            k0,
            origin_latitude,
            false_origin,
        )))
    }

    /// Ground metres per projected metre along x and along y at (x, y), and the
    /// cosine of the angle between the two axes on the ground (0: square).
    pub fn axis_scales(&self, x: f64, y: f64) -> ([f64; 2], f64) {
        match &self.0 {
            Kind::Conformal(p) => ([p.ground_per_unit(x, y); 2], 0.0),
            Kind::EqualArea(p) => p.axis_scales(x, y),
            Kind::Numeric(p) => p.axis_scales(x, y),
        }
    }

    /// Whether the projection is measured through PROJ's inverse, having no formula here.
    pub fn is_numeric(&self) -> bool {
        matches!(self.0, Kind::Numeric(_))
    }

    /// A projection with no formula here, measured through PROJ's inverse, from a PROJ
    /// string whose coordinates are metres (any `+units` or `+to_meter` is dropped);
    /// `None` for geographic CRSs and projections `proj4rs` does not carry.
    pub fn numeric(definition: &str) -> Option<Projection> {
        let in_metres: Vec<&str> = definition
            .split_whitespace()
            .filter(|term| !term.starts_with("+units=") && !term.starts_with("+to_meter="))
            .collect();
        Numeric::of(&in_metres.join(" ")).map(|p| Projection(Kind::Numeric(Box::new(p))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn web_mercator_units_shrink_with_the_cosine_of_the_latitude() {
        // On the equator a unit east is a ground metre (N = A there) and a unit north
        // M(0)/A = 1 − e² ≈ 0.9933.
        let [e, n] = metres_per_web_mercator_unit(0.0);
        assert!((e - 1.0).abs() < 1e-12, "{e}");
        assert!((n - (1.0 - E2)).abs() < 1e-9, "{n}");
        // Northing 4 803 914 m (the bottom of a real 3857 hillshade) lies at 39.57° N;
        // northing of 60° N is A·ln(tan 75°) ≈ 8 399 738 m, where a unit spans about
        // cos 60° = 0.5 ground metres (east 0.5·N/A = 0.5013, north 0.5·M/A = 0.5004).
        assert!((web_mercator_latitude(4_803_914.35) - 39.572).abs() < 0.001);
        let sixty = A * (75f64.to_radians().tan()).ln();
        assert!((web_mercator_latitude(sixty) - 60.0).abs() < 1e-9);
        let [e, n] = metres_per_web_mercator_unit(sixty);
        assert!((e - 0.5013).abs() < 1e-4, "{e}");
        assert!((n - 0.5004).abs() < 1e-4, "{n}");
        // Symmetric about the equator.
        assert_eq!(metres_per_web_mercator_unit(-sixty), [e, n]);
    }

    #[test]
    fn polar_stereographic_and_world_mercator_scales() {
        // NSIDC North (3413) is true to scale at 70° N: a point there lies
        // ρ = A·m(70°) from the pole, where a projected metre is a ground metre.
        let e = eccentricity();
        let m = |lat: f64| {
            let phi = f64::to_radians(lat);
            phi.cos() / (1.0 - E2 * phi.sin().powi(2)).sqrt()
        };
        let at_70 = A * m(70.0);
        let scale = |code, x, y| Projection::of_epsg(code).unwrap().axis_scales(x, y).0[0];
        assert!((scale(3413, at_70, 0.0) - 1.0).abs() < 1e-9);
        assert!((scale(3031, 0.0, -A * m(71.0)) - 1.0).abs() < 1e-9);
        // At the pole the scale is m_c / (2 t_c)·√((1+e)^(1+e)(1−e)^(1−e)) ≈ 0.9700
        // for 70° (the sphere's (1 + sin 70°)/2 = 0.9698): a metre spans 1.031 m.
        let pole = scale(3413, 0.0, 0.0);
        assert!((1.0 / pole - 0.9700).abs() < 5e-4, "{pole}");
        assert_eq!(scale(3413, 1e-9, 0.0), pole);
        // UPS is scaled 0.994 at the pole, from a false origin of 2 000 km.
        assert!((scale(32661, 2.0e6, 2.0e6) - 1.0 / 0.994).abs() < 1e-12);
        // Away from the pole both grow: at 60° N the sphere's k = (1 + sin 70°) /
        // (1 + sin 60°) = 1.0395, so a projected metre spans 0.962 ground metres.
        let sixty = scale(3995, 0.0, 3.0e6);
        assert!(sixty < 1.0 && sixty > 0.95, "{sixty}");
        // World Mercator: y of 60° N is A·ln(tan 75°·((1 − e sin 60°)/(1 + e sin
        // 60°))^(e/2)), where a metre spans m(60°) ground metres (about 0.5).
        let s60 = e * 60f64.to_radians().sin();
        let y60 = A * (75f64.to_radians().tan() * ((1.0 - s60) / (1.0 + s60)).powf(e / 2.0)).ln();
        assert!((scale(3395, 0.0, y60) - m(60.0)).abs() < 1e-12);
        assert!((scale(3395, 0.0, -y60) - m(60.0)).abs() < 1e-12);
    }

    #[test]
    fn mercator_is_measured_from_its_latitude_of_true_scale() {
        // PROJ's inverse of `+proj=merc +lat_ts=41 +datum=WGS84` at 10 m steps east
        // (rasterio.warp.transform), measured as chords on WGS 84: ground metres per
        // projected metre at 41° N (1), at the equator and at 60° N.
        let mercator_41 = Projection::mercator(Ellipsoid::WGS84, Some(41.0), 1.0, 0.0);
        let ground = |y: f64| mercator_41.axis_scales(0.0, y).0[0];
        let k0 = m(41f64.to_radians());
        let s41 = eccentricity() * 41f64.to_radians().sin();
        let y41 = A
            * k0
            * (65.5f64.to_radians().tan() * ((1.0 - s41) / (1.0 + s41)).powf(eccentricity() / 2.0))
                .ln();
        assert!((ground(y41) - 1.0).abs() < 1e-12);
        assert!((ground(-y41) - 1.0).abs() < 1e-12);
        assert!((ground(0.0) - 1.0 / k0).abs() < 1e-12);
        assert!((ground(0.0) - 1.323_102_7).abs() < 1e-6, "{}", ground(0.0));
        // One parallel's scale given as k0 is the same projection.
        let scaled = Projection::mercator(Ellipsoid::WGS84, None, k0, 0.0);
        assert_eq!(
            scaled.axis_scales(0.0, y41),
            mercator_41.axis_scales(0.0, y41)
        );
        // A false northing moves the equator.
        let moved = Projection::mercator(Ellipsoid::WGS84, Some(41.0), 1.0, 1.0e6);
        assert_eq!(moved.axis_scales(0.0, 1.0e6 + y41).0, [ground(y41); 2]);
        // On a sphere of 6371 km (`+proj=merc +R=6371000`), 2500 m south of 60° N's
        // northing, PROJ's chord measures 0.500170 ground metres per metre.
        let sphere = Projection::mercator(Ellipsoid::sphere(6.371e6), None, 1.0, 0.0);
        let y60 = 6.371e6 * 75f64.to_radians().tan().ln();
        let [east, _] = sphere.axis_scales(30.0, y60 - 2500.0).0;
        assert!((east - 0.500_169_9).abs() < 1e-6, "{east}");
    }

    #[test]
    fn transverse_mercator_is_measured_far_from_its_meridian() {
        // PROJ's inverses at x ± 10 m (rasterio.warp.transform), measured as chords on
        // WGS 84: ground metres per projected metre.
        let by_code = |code| Projection::of_epsg(code).unwrap();
        for (projection, x, y, expected) in [
            // UTM 33N 1000 km and 2000 km east of its meridian, 700 km west of it.
            (by_code(32633), 1.5e6, 5.0e6, 0.988_219_404_8),
            (by_code(32633), 2.5e6, 6.0e6, 0.953_210_425_8),
            (by_code(32633), -2.0e5, 1.0e6, 0.994_362_141_9),
            // UTM 33S, 400 km east.
            (by_code(32733), 9.0e5, 8.0e6, 0.998_423_792_1),
            // NAD83 / UTM 15N, 300 km west: at 0.9993 inside 0.1 % of true scale.
            (by_code(26915), 2.0e5, 4.5e6, 1.0),
            // UTM 33N on its meridian (0.9996): read as it is.
            (by_code(32633), 5.0e5, 5.0e6, 1.0),
            // A user-defined grid: Germany's zone 4 (k0 = 1) 800 km east of it.
            (
                Projection::transverse_mercator(1.0, 4.5e6),
                5.3e6,
                5.4e6,
                0.992_191_657_6,
            ),
        ] {
            let ([sx, sy], skew) = projection.axis_scales(x, y);
            assert!(
                (sx - expected).abs() < 1e-4,
                "{x} {y}: {sx} against {expected}"
            );
            assert_eq!((sx, skew), (sy, 0.0));
        }
    }

    #[test]
    fn lambert_conformal_scales_agree_with_proj() {
        // PROJ's inverses at x ± 10 m (rasterio.warp.transform), measured as chords on
        // WGS 84: ground metres per projected metre.
        let lambert_2sp = Projection::lambert_conformal([33.0, 45.0], 1.0, 39.0, [0.0; 2]);
        let lambert_1sp = Projection::lambert_conformal([18.0; 2], 1.0, 18.0, [2.5e5, 1.5e5]);
        let by_code = |code| Projection::of_epsg(code).unwrap();
        for (projection, x, y, expected) in [
            (by_code(2154), 7.0e5, 6.6e6, 1.000_949_815_39),
            (by_code(2154), 1.0e6, 7.0e6, 0.999_038_078_33),
            (by_code(3034), 4.0e6, 2.8e6, 1.035_387_849_74),
            (by_code(3034), 3.0e6, 1.5e6, 1.015_929_927_50),
            (by_code(3978), 1.5e6, 2.0e6, 1.031_463_845_94),
            (by_code(3347), 6.2e6, 3.0e6, 1.031_393_530_18),
            (by_code(3347), 7.0e6, 1.0e6, 0.981_062_837_32),
            (lambert_2sp, 1.0e6, -5.0e5, 1.001_538_818_19),
            (lambert_1sp, 3.0e5, 2.0e5, 0.999_969_159_40),
        ] {
            let ([sx, sy], skew) = projection.axis_scales(x, y);
            assert!(
                (sx - expected).abs() < 1e-8,
                "({x}, {y}): {sx} against {expected}"
            );
            assert_eq!((sx, skew), (sy, 0.0));
        }
    }

    #[test]
    fn known_lengths_of_a_degree() {
        // Standard tables: at the equator 111 319.5 m of longitude and 110 574.4 m of
        // latitude; at 45° 78 846.8 m and 111 132.1 m; at 60° 55 799.9 and 111 412.2.
        for (lat, east, north) in [
            (0.0, 111_319.49, 110_574.27),
            (45.0, 78_846.81, 111_131.75),
            (60.0, 55_799.98, 111_412.24),
        ] {
            let [e, n] = metres_per_degree(lat);
            assert!((e - east).abs() < 1.0, "{lat}: {e}");
            assert!((n - north).abs() < 1.0, "{lat}: {n}");
        }
    }
}
