//! The equal-area projections continental and global rasters come in: Albers conic (the
//! USGS's CONUS grid, EPSG:5070, as NLCD and 3DEP products come; Australia's 3577),
//! Lambert azimuthal (LAEA Europe, EPSG:3035, as EU-DEM and CORINE come; the polar EASE
//! grids), and the world grids: sinusoidal (MODIS), cylindrical (EASE-Grid 2.0),
//! Mollweide (GHSL) and Equal Earth. Away from their standard lines they stretch one
//! axis by what they shrink the other, 1–2 % across a continent and far more across the
//! world grids, whose axes also shear apart, so a projected metre is not a ground metre
//! on either axis. Snyder's ellipsoidal inverses (Map Projections: A Working Manual,
//! 1987) and PROJ's for Equal Earth take a projected point back to latitude and
//! longitude, where the ground is measured.

/// An ellipsoid by its semi-major axis (m) and first eccentricity squared (0: a sphere).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipsoid {
    pub a: f64,
    pub e2: f64,
}

impl Ellipsoid {
    /// WGS 84 (GRS 80's flattening differs in the eleventh digit: the same here).
    pub const WGS84: Ellipsoid = Ellipsoid {
        a: 6_378_137.0,
        e2: 6.694_379_990_141_3e-3,
    };
    /// Clarke 1866 (NAD27).
    pub const CLARKE_1866: Ellipsoid = Ellipsoid {
        a: 6_378_206.4,
        e2: 6.768_657_997_291e-3,
    };

    /// From the semi-major axis and the inverse flattening (0 or infinite: a sphere).
    pub fn from_inverse_flattening(a: f64, inverse_flattening: f64) -> Ellipsoid {
        let f = if inverse_flattening.is_finite() && inverse_flattening != 0.0 {
            1.0 / inverse_flattening
        } else {
            0.0
        };
        Ellipsoid {
            a,
            e2: f * (2.0 - f),
        }
    }

    /// A sphere of radius `r` (the EASE grids' and the US National Atlas's).
    pub fn sphere(r: f64) -> Ellipsoid {
        Ellipsoid { a: r, e2: 0.0 }
    }

    fn e(&self) -> f64 {
        self.e2.sqrt()
    }

    /// m(φ) = cos φ / √(1 − e² sin² φ): the parallel's radius over a.
    pub(crate) fn m(&self, phi: f64) -> f64 {
        phi.cos() / (1.0 - self.e2 * phi.sin().powi(2)).sqrt()
    }

    /// q(φ), Snyder's (3-12): the authalic sphere's sin β scaled so that q(90°) = q_p.
    fn q(&self, phi: f64) -> f64 {
        let s = phi.sin();
        if self.e2 < 1e-12 {
            return 2.0 * s;
        }
        let e = self.e();
        (1.0 - self.e2)
            * (s / (1.0 - self.e2 * s * s) - ((1.0 - e * s) / (1.0 + e * s)).ln() / (2.0 * e))
    }

    /// The latitude whose q is `q`.
    fn latitude_of_q(&self, q: f64) -> f64 {
        let sin_beta = (q / self.q(std::f64::consts::FRAC_PI_2)).clamp(-1.0, 1.0);
        self.latitude_of_authalic(sin_beta.asin())
    }

    /// The latitude of authalic latitude `beta`: the series (3-18), then Newton's steps
    /// on (3-16) to full precision away from the poles (near them the series alone is
    /// exact to a part in 10⁹ of the distance to the pole, and the steps are not).
    fn latitude_of_authalic(&self, beta: f64) -> f64 {
        let (e2, e4, e6) = (self.e2, self.e2 * self.e2, self.e2.powi(3));
        let mut phi = beta
            + (e2 / 3.0 + 31.0 * e4 / 180.0 + 517.0 * e6 / 5040.0) * (2.0 * beta).sin()
            + (23.0 * e4 / 360.0 + 251.0 * e6 / 3780.0) * (4.0 * beta).sin()
            + (761.0 * e6 / 45360.0) * (6.0 * beta).sin();
        if self.e2 < 1e-12 {
            return phi;
        }
        let q = self.q(std::f64::consts::FRAC_PI_2) * beta.sin();
        for _ in 0..3 {
            let (s, c) = phi.sin_cos();
            if c.abs() < 1e-3 {
                break;
            }
            let w = 1.0 - self.e2 * s * s;
            phi += w * w / (2.0 * c) * (q - self.q(phi)) / (1.0 - self.e2);
        }
        phi
    }

    /// The latitude whose meridian arc from the equator is `arc` metres: Snyder's
    /// series (3-26) for a first guess, then Newton's steps on the arc (7-19).
    fn footpoint_latitude(&self, arc: f64) -> f64 {
        let e2 = self.e2;
        let rectifying =
            self.a * (1.0 - e2 / 4.0 - 3.0 * e2 * e2 / 64.0 - 5.0 * e2.powi(3) / 256.0);
        let mu = arc / rectifying;
        let root = (1.0 - e2).sqrt();
        let e1 = (1.0 - root) / (1.0 + root);
        let mut phi = mu
            + (1.5 * e1 - 27.0 * e1.powi(3) / 32.0) * (2.0 * mu).sin()
            + (21.0 * e1 * e1 / 16.0 - 55.0 * e1.powi(4) / 32.0) * (4.0 * mu).sin()
            + (151.0 * e1.powi(3) / 96.0) * (6.0 * mu).sin()
            + (1097.0 * e1.powi(4) / 512.0) * (8.0 * mu).sin();
        for _ in 0..3 {
            // dM/dφ is the meridian's radius of curvature a(1 − e²)/(1 − e² sin²φ)^1.5.
            let w = 1.0 - e2 * phi.sin().powi(2);
            phi -= (self.meridian_arc(phi) - arc) * w * w.sqrt() / (self.a * (1.0 - e2));
        }
        phi
    }

    /// The meridian's arc from the equator to latitude `phi` (Snyder 3-21), metres.
    fn meridian_arc(&self, phi: f64) -> f64 {
        let (e2, e4, e6) = (self.e2, self.e2 * self.e2, self.e2.powi(3));
        self.a
            * ((1.0 - e2 / 4.0 - 3.0 * e4 / 64.0 - 5.0 * e6 / 256.0) * phi
                - (3.0 * e2 / 8.0 + 3.0 * e4 / 32.0 + 45.0 * e6 / 1024.0) * (2.0 * phi).sin()
                + (15.0 * e4 / 256.0 + 45.0 * e6 / 1024.0) * (4.0 * phi).sin()
                - (35.0 * e6 / 3072.0) * (6.0 * phi).sin())
    }

    /// Earth-centred coordinates (m) of latitude `phi`, longitude `lambda` (radians).
    pub fn ecef(&self, phi: f64, lambda: f64) -> [f64; 3] {
        let n = self.a / (1.0 - self.e2 * phi.sin().powi(2)).sqrt();
        [
            n * phi.cos() * lambda.cos(),
            n * phi.cos() * lambda.sin(),
            n * (1.0 - self.e2) * phi.sin(),
        ]
    }
}

/// An equal-area projection with its parameters (degrees and metres, as EPSG and the
/// GeoKeys give them).
#[derive(Debug, Clone, PartialEq)]
pub enum EqualArea {
    /// Albers equal-area conic, true to scale on two standard parallels.
    Albers {
        ellipsoid: Ellipsoid,
        standard_parallels: [f64; 2],
        /// Latitude and longitude of the origin.
        origin: [f64; 2],
        false_easting_northing: [f64; 2],
    },
    /// Lambert azimuthal equal-area, true to scale only at its centre.
    Azimuthal {
        ellipsoid: Ellipsoid,
        /// Latitude and longitude of the centre.
        centre: [f64; 2],
        false_easting_northing: [f64; 2],
    },
    /// Sinusoidal, true to scale along every parallel, its meridians sheared apart
    /// away from the central one: the MODIS land products' grid (on a sphere of
    /// 6 371 007.181 m).
    Sinusoidal {
        ellipsoid: Ellipsoid,
        central_meridian: f64,
        false_easting_northing: [f64; 2],
    },
    /// Cylindrical equal-area, true to scale on its two standard parallels ±φs and
    /// stretched east-west poleward of them: the EASE-Grid 2.0 global grid (EPSG:6933).
    Cylindrical {
        ellipsoid: Ellipsoid,
        standard_parallel: f64,
        central_meridian: f64,
        false_easting_northing: [f64; 2],
    },
    /// Mollweide, on a sphere of radius `radius` (PROJ takes the ellipsoid's
    /// semi-major axis): global grids such as GHSL's (ESRI:54009).
    Mollweide {
        radius: f64,
        central_meridian: f64,
        false_easting_northing: [f64; 2],
    },
    /// Equal Earth (Šavrič, Patterson & Jenny 2018) through the ellipsoid's authalic
    /// latitude, as PROJ computes it (EPSG:8857).
    EqualEarth {
        ellipsoid: Ellipsoid,
        central_meridian: f64,
        false_easting_northing: [f64; 2],
    },
}

/// Equal Earth's polynomial coefficients and √3 / 2.
const EQUAL_EARTH: [f64; 4] = [1.340_264, -0.081_106, 0.000_893, 0.003_796];
const HALF_ROOT_3: f64 = 0.866_025_403_784_438_6;

impl EqualArea {
    /// The projections known by their EPSG code.
    pub fn of_epsg(code: u16) -> Option<EqualArea> {
        use Ellipsoid as E;
        let albers = |ellipsoid, parallels, origin, false_origin| EqualArea::Albers {
            ellipsoid,
            standard_parallels: parallels,
            origin,
            false_easting_northing: false_origin,
        };
        let azimuthal = |ellipsoid, centre, false_origin| EqualArea::Azimuthal {
            ellipsoid,
            centre,
            false_easting_northing: false_origin,
        };
        let cylindrical = |ellipsoid, standard_parallel| EqualArea::Cylindrical {
            ellipsoid,
            standard_parallel,
            central_meridian: 0.0,
            false_easting_northing: [0.0; 2],
        };
        let conus = [[29.5, 45.5], [23.0, -96.0]];
        Some(match code {
            // NAD83 (and its realisations) / Conus Albers; NAD27's on Clarke 1866.
            5070 | 5072 | 6350 => albers(E::WGS84, conus[0], conus[1], [0.0; 2]),
            5069 => albers(E::CLARKE_1866, conus[0], conus[1], [0.0; 2]),
            3338 => albers(E::WGS84, [55.0, 65.0], [50.0, -154.0], [0.0; 2]), // Alaska Albers
            3310 => albers(E::WGS84, [34.0, 40.5], [0.0, -120.0], [0.0, -4.0e6]), // California
            3083 => albers(E::WGS84, [27.5, 35.0], [18.0, -100.0], [1.5e6, 6.0e6]), // Texas
            3005 => albers(E::WGS84, [50.0, 58.5], [45.0, -126.0], [1.0e6, 0.0]), // BC Albers
            // GDA94 and GDA2020 / Australian Albers.
            3577 | 9473 => albers(E::WGS84, [-18.0, -36.0], [0.0, 132.0], [0.0; 2]),
            // ETRS89-extended / LAEA Europe.
            3035 => azimuthal(E::WGS84, [52.0, 10.0], [4_321_000.0, 3_210_000.0]),
            // NSIDC EASE-Grid 2.0 North and South.
            6931 => azimuthal(E::WGS84, [90.0, 0.0], [0.0; 2]),
            6932 => azimuthal(E::WGS84, [-90.0, 0.0], [0.0; 2]),
            // WGS 84 / North Pole LAEA Bering Sea, Alaska, Canada, Atlantic, Europe, Russia.
            3571..=3576 => {
                let longitude =
                    [180.0, -150.0, -100.0, -40.0, 10.0, 90.0][usize::from(code - 3571)];
                azimuthal(E::WGS84, [90.0, longitude], [0.0; 2])
            }
            // US National Atlas Equal Area: on Clarke 1866 (9311), on a sphere (2163).
            9311 => azimuthal(E::CLARKE_1866, [45.0, -100.0], [0.0; 2]),
            2163 => azimuthal(E::sphere(6_370_997.0), [45.0, -100.0], [0.0; 2]),
            // NSIDC EASE-Grid North and South, on a sphere.
            3408 => azimuthal(E::sphere(6_371_228.0), [90.0, 0.0], [0.0; 2]),
            3409 => azimuthal(E::sphere(6_371_228.0), [-90.0, 0.0], [0.0; 2]),
            // EASE-Grid 2.0 global (WGS 84) and the first EASE-Grid global (a sphere).
            6933 => cylindrical(E::WGS84, 30.0),
            3410 => cylindrical(E::sphere(6_371_228.0), 30.0),
            // WGS 84 / Equal Earth Greenwich, Americas and Asia-Pacific.
            8857..=8859 => EqualArea::EqualEarth {
                ellipsoid: E::WGS84,
                central_meridian: [0.0, -90.0, 150.0][usize::from(code - 8857)],
                false_easting_northing: [0.0; 2],
            },
            _ => return None,
        })
    }

    /// Latitude and longitude (radians) of projected point (x, y) in metres.
    pub fn inverse(&self, x: f64, y: f64) -> (f64, f64) {
        match self {
            EqualArea::Albers {
                ellipsoid: el,
                standard_parallels,
                origin,
                false_easting_northing: [fe, fn_],
            } => {
                let [phi1, phi2] = standard_parallels.map(f64::to_radians);
                let [phi0, lambda0] = origin.map(f64::to_radians);
                let (m1, m2) = (el.m(phi1), el.m(phi2));
                let (q1, q2) = (el.q(phi1), el.q(phi2));
                // One standard parallel: the limit of (14-14) is sin φ1.
                let n = if (phi1 - phi2).abs() < 1e-12 {
                    phi1.sin()
                } else {
                    (m1 * m1 - m2 * m2) / (q2 - q1)
                };
                let c = m1 * m1 + n * q1;
                let rho0 = el.a * (c - n * el.q(phi0)).max(0.0).sqrt() / n;
                let (x, y) = (x - fe, y - fn_);
                // (14-10), (14-11): ρ and θ take the sign of n.
                let sign = n.signum();
                let rho = sign * x.hypot(rho0 - y);
                let theta = (sign * x).atan2(sign * (rho0 - y));
                let q = (c - rho * rho * n * n / (el.a * el.a)) / n;
                (el.latitude_of_q(q), lambda0 + theta / n)
            }
            EqualArea::Azimuthal {
                ellipsoid: el,
                centre,
                false_easting_northing: [fe, fn_],
            } => {
                let [phi1, lambda0] = centre.map(f64::to_radians);
                let (x, y) = (x - fe, y - fn_);
                let qp = el.q(std::f64::consts::FRAC_PI_2);
                if (phi1.abs() - std::f64::consts::FRAC_PI_2).abs() < 1e-12 {
                    // The polar aspects (24-25 … 24-28): q = ±(q_p − ρ²/a²), so that
                    // 1 − sin β = t = ρ² / (a² q_p), and β comes from t without the
                    // cancellation of asin near the pole.
                    let t = ((x * x + y * y) / (el.a * el.a * qp)).min(2.0);
                    let beta = (1.0 - t).atan2((t * (2.0 - t)).sqrt()) * phi1.signum();
                    let lambda = if phi1 > 0.0 { x.atan2(-y) } else { x.atan2(y) };
                    return (el.latitude_of_authalic(beta), lambda0 + lambda);
                }
                // The oblique aspect (24-12 … 24-30).
                let rq = el.a * (qp / 2.0).sqrt();
                let beta1 = (el.q(phi1) / qp).clamp(-1.0, 1.0).asin();
                let d = el.a * el.m(phi1) / (rq * beta1.cos());
                let rho = (x / d).hypot(d * y);
                if rho < 1e-9 {
                    return (phi1, lambda0);
                }
                let ce = 2.0 * (rho / (2.0 * rq)).clamp(-1.0, 1.0).asin();
                let (sin_ce, cos_ce) = ce.sin_cos();
                let q = qp * (cos_ce * beta1.sin() + d * y * sin_ce * beta1.cos() / rho);
                let lambda = (x * sin_ce)
                    .atan2(d * rho * beta1.cos() * cos_ce - d * d * y * beta1.sin() * sin_ce);
                (el.latitude_of_q(q), lambda0 + lambda)
            }
            EqualArea::Sinusoidal {
                ellipsoid: el,
                central_meridian,
                false_easting_northing: [fe, fn_],
            } => {
                // Snyder §30 on the ellipsoid: y is the meridian's arc M(φ), and
                // x = (λ − λ0) a m(φ).
                let phi = el.footpoint_latitude(y - fn_);
                let lambda = (x - fe) / (el.a * el.m(phi));
                (phi, central_meridian.to_radians() + lambda)
            }
            EqualArea::Cylindrical {
                ellipsoid: el,
                standard_parallel,
                central_meridian,
                false_easting_northing: [fe, fn_],
            } => {
                // Snyder §10 on the ellipsoid: x = a k0 (λ − λ0), y = a q / (2 k0).
                let k0 = el.m(standard_parallel.to_radians());
                let phi = el.latitude_of_q(2.0 * k0 * (y - fn_) / el.a);
                (phi, central_meridian.to_radians() + (x - fe) / (el.a * k0))
            }
            EqualArea::Mollweide {
                radius,
                central_meridian,
                false_easting_northing: [fe, fn_],
            } => {
                // Snyder §31: the auxiliary angle θ from y, then φ and λ.
                let root2 = std::f64::consts::SQRT_2;
                let theta = ((y - fn_) / (root2 * radius)).clamp(-1.0, 1.0).asin();
                let phi = ((2.0 * theta + (2.0 * theta).sin()) / std::f64::consts::PI)
                    .clamp(-1.0, 1.0)
                    .asin();
                let lambda = std::f64::consts::PI * (x - fe) / (2.0 * root2 * radius * theta.cos());
                (phi, central_meridian.to_radians() + lambda)
            }
            EqualArea::EqualEarth {
                ellipsoid: el,
                central_meridian,
                false_easting_northing: [fe, fn_],
            } => {
                // PROJ's eqearth: the parametric latitude ψ (sin ψ = √3/2 sin β) from y by
                // Newton's steps, then λ and the authalic latitude β.
                let [a1, a2, a3, a4] = EQUAL_EARTH;
                let rq = el.a * (el.q(std::f64::consts::FRAC_PI_2) / 2.0).sqrt();
                let (x, y) = ((x - fe) / rq, (y - fn_) / rq);
                let derivative = |p2: f64| {
                    let p6 = p2 * p2 * p2;
                    a1 + 3.0 * a2 * p2 + p6 * (7.0 * a3 + 9.0 * a4 * p2)
                };
                let mut psi = y;
                for _ in 0..12 {
                    let (p2, p6) = (psi * psi, psi.powi(6));
                    let step = (psi * (a1 + a2 * p2 + p6 * (a3 + a4 * p2)) - y) / derivative(p2);
                    psi -= step;
                    if step.abs() < 1e-12 {
                        break;
                    }
                }
                let lambda = HALF_ROOT_3 * x * derivative(psi * psi) / psi.cos();
                let beta = (psi.sin() / HALF_ROOT_3).clamp(-1.0, 1.0).asin();
                (
                    el.latitude_of_authalic(beta),
                    central_meridian.to_radians() + lambda,
                )
            }
        }
    }

    /// Ground metres (on WGS 84) per projected metre along x and along y at (x, y), and
    /// the cosine of the angle the two axes make on the ground: central differences of
    /// the inverse over 10 m, measured as chords between earth-centred points (exact
    /// to a part in 10¹², and free of the longitude's singularity at the poles).
    pub fn axis_scales(&self, x: f64, y: f64) -> ([f64; 2], f64) {
        const H: f64 = 10.0;
        let ground = |x: f64, y: f64| {
            let (phi, lambda) = self.inverse(x, y);
            Ellipsoid::WGS84.ecef(phi, lambda)
        };
        let difference = |a: [f64; 3], b: [f64; 3]| [0, 1, 2].map(|i| (a[i] - b[i]) / (2.0 * H));
        let along_x = difference(ground(x + H, y), ground(x - H, y));
        let along_y = difference(ground(x, y + H), ground(x, y - H));
        let norm = |v: [f64; 3]| v.iter().map(|c| c * c).sum::<f64>().sqrt();
        let dot: f64 = (0..3).map(|i| along_x[i] * along_y[i]).sum();
        let (sx, sy) = (norm(along_x), norm(along_y));
        ([sx, sy], dot / (sx * sy))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Checks `projection`'s inverse of (x, y) against (latitude, longitude) in degrees.
    fn inverts_to(projection: &EqualArea, x: f64, y: f64, lat: f64, lon: f64, tolerance: f64) {
        let (phi, lambda) = projection.inverse(x, y);
        let (got_lat, got_lon) = (phi.to_degrees(), lambda.to_degrees());
        let lon_error = (got_lon - lon + 540.0).rem_euclid(360.0) - 180.0;
        assert!(
            (got_lat - lat).abs() < tolerance && lon_error.abs() < tolerance,
            "{projection:?} at ({x}, {y}): ({got_lat}, {got_lon}), not ({lat}, {lon})"
        );
    }

    #[test]
    fn inverses_agree_with_proj() {
        // Snyder's worked example (p. 292): Conus Albers on Clarke 1866, (35° N, 75° W)
        // projects to (1 885 472.7, 1 535 925.0) m.
        let conus_nad27 = EqualArea::of_epsg(5069).unwrap();
        inverts_to(&conus_nad27, 1_885_472.7, 1_535_925.0, 35.0, -75.0, 1e-6);
        // The rest: PROJ 9's inverses (rasterio.warp.transform with the same
        // projection on GRS 80 and no datum shift), to a nanodegree.
        let cases = [
            (
                5070,
                1_885_472.7,
                1_535_925.0,
                34.999_527_009_1,
                -74.999_629_626_0,
            ),
            (5070, -2.0e6, 3.0e6, 47.447_095_704_1, -122.704_964_266_7),
            (3577, 1.0e6, -3.0e6, -27.294_975_231_4, 142.237_756_938_2),
            (3310, -2.0e5, -1.0e5, 37.095_410_540_3, -122.253_514_051_7),
            (3035, 5.0e6, 4.5e6, 63.015_361_545_7, 23.438_962_074_0),
            (3035, 2.5e6, 1.5e6, 34.427_825_388_1, -9.826_342_517_2),
            (3035, 4_321_000.0, 3_210_000.0, 52.0, 10.0),
            (3573, 1.0e6, -3.0e6, 61.368_678_535_9, -81.565_051_177_1),
            (3573, -2.0e6, 5.0e5, 71.455_664_967_6, 155.963_756_532_1),
            (6932, 1.0e6, -3.0e6, -61.368_678_535_9, 161.565_051_177_1),
        ];
        for (code, x, y, lat, lon) in cases {
            inverts_to(&EqualArea::of_epsg(code).unwrap(), x, y, lat, lon, 1e-9);
        }
        assert!(EqualArea::of_epsg(32610).is_none());
    }

    #[test]
    fn world_grids_invert_as_proj_does() {
        // PROJ 9's inverses (rasterio.warp.transform), to 1e-8° (a millimetre).
        let sinusoidal = |ellipsoid| EqualArea::Sinusoidal {
            ellipsoid,
            central_meridian: 0.0,
            false_easting_northing: [0.0; 2],
        };
        let modis = sinusoidal(Ellipsoid::sphere(6_371_007.181));
        let esri_54008 = sinusoidal(Ellipsoid::WGS84);
        let esri_54009 = EqualArea::Mollweide {
            radius: 6_378_137.0,
            central_meridian: 0.0,
            false_easting_northing: [0.0; 2],
        };
        let epsg = |code| EqualArea::of_epsg(code).unwrap();
        let cases = [
            (&modis, -8.0e6, 4.4e6, 39.570_106_059_4, -93.333_395_030_1),
            (&modis, 1.2e6, -3.3e6, -29.677_579_544_6, 12.421_193_053_6),
            (
                &esri_54008,
                -8.0e6,
                4.4e6,
                39.734_049_558_3,
                -93.322_518_770_4,
            ),
            (
                &esri_54008,
                3.0e6,
                6.0e6,
                54.126_533_597_9,
                45.887_874_000_1,
            ),
            (
                &esri_54009,
                -8.0e6,
                4.4e6,
                36.547_840_915_1,
                -91.439_159_958_9,
            ),
            (
                &esri_54009,
                1.0e6,
                7.5e6,
                66.793_140_437_9,
                17.960_078_459_3,
            ),
        ];
        for (projection, x, y, lat, lon) in cases {
            inverts_to(projection, x, y, lat, lon, 1e-8);
        }
        for (code, x, y, lat, lon) in [
            (6933, -8.0e6, 4.4e6, 36.941_034_079_6, -82.913_342_489_7),
            (6933, 1.5e7, -6.0e6, -54.925_275_196_1, 155.462_517_168_2),
            (3410, -8.0e6, 4.4e6, 36.732_597_967_8, -83.072_798_462_9),
            (8857, -8.0e6, 4.4e6, 35.412_474_134_7, -91.663_460_497_5),
            (8857, 1.0e7, -7.0e6, -60.890_904_487_2, 139.646_768_501_3),
            (8858, 1.0e6, 4.0e6, 31.986_307_481_1, -78.741_772_676_5),
            (8859, 1.0e6, 4.0e6, 31.986_307_481_1, 161.258_227_323_5),
        ] {
            inverts_to(&epsg(code), x, y, lat, lon, 1e-8);
        }
    }

    #[test]
    fn world_grids_stretch_and_shear_their_axes() {
        // MODIS's sinusoidal grid over Iowa (39.6° N, 93.3° W): a unit east is a ground
        // metre, a unit north runs 1.6 rad · sin 39.6° ≈ 1.04 east for each north, so
        // it spans √(1 + 1.04²) ≈ 1.44 m and leans 46° from the x axis's normal.
        let modis = EqualArea::Sinusoidal {
            ellipsoid: Ellipsoid::sphere(6_371_007.181),
            central_meridian: 0.0,
            false_easting_northing: [0.0; 2],
        };
        let ([sx, sy], skew) = modis.axis_scales(-8.0e6, 4.4e6);
        assert!(
            (sx - 1.0).abs() < 0.01 && (sy - 1.44).abs() < 0.02,
            "{sx} {sy}"
        );
        assert!((skew.abs() - 0.72).abs() < 0.01, "{skew}");
        // EASE-Grid 2.0 at 36.9° N: parallels stretched by cos 30° / cos 36.9° ≈ 1.083,
        // meridians shrunk by as much; square on the ground.
        let ([sx, sy], skew) = EqualArea::of_epsg(6933).unwrap().axis_scales(-8.0e6, 4.4e6);
        assert!(
            (sx - 1.0 / 1.083).abs() < 0.003 && (sy - 1.083).abs() < 0.003,
            "{sx} {sy}"
        );
        assert!(skew.abs() < 1e-6, "{skew}");
    }

    #[test]
    fn scales_agree_with_proj() {
        // PROJ's inverses at x ± 10 m and y ± 10 m (rasterio.warp.transform), measured as
        // chords on WGS 84: at 60.0135° N 123° W in Conus Albers (far north of its
        // standard parallels, 27° off its meridian: the axes 6.3° from square) and in a
        // user-defined Albers cone on that meridian; at 37.5° N on Conus Albers's.
        let conus = EqualArea::of_epsg(5070).unwrap();
        let on_meridian = EqualArea::Albers {
            ellipsoid: Ellipsoid::WGS84,
            standard_parallels: [29.5, 45.5],
            origin: [23.0, -123.0],
            false_easting_northing: [0.0; 2],
        };
        for (projection, x, y, expected, expected_skew) in [
            (
                &conus,
                -1_646_463.864_369_742,
                4_290_570.739_334_132,
                [0.920_251_603_559, 1.093_366_868_083],
                0.110_597_727_073,
            ),
            (
                &on_meridian,
                0.0,
                4_055_095.212_586_672,
                [0.902_423_367_228, 1.108_127_334_005],
                0.0,
            ),
            (
                &conus,
                0.0,
                1_606_786.260_577_336,
                [1.009_757_355_885, 0.990_336_930_092],
                0.0,
            ),
        ] {
            let ([sx, sy], skew) = projection.axis_scales(x, y);
            assert!(
                (sx - expected[0]).abs() < 1e-8 && (sy - expected[1]).abs() < 1e-8,
                "{sx} {sy} against {expected:?}"
            );
            assert!((skew - expected_skew).abs() < 1e-8, "{skew}");
        }
    }

    #[test]
    fn scales_are_one_on_the_standard_lines_and_keep_areas() {
        // At an Albers grid's origin meridian, on a standard parallel, both axes are
        // true to scale; between the parallels x shrinks and y stretches, with their
        // product 1 (equal area) and the axes square on the ground.
        let conus = EqualArea::of_epsg(5070).unwrap();
        let el = Ellipsoid::WGS84;
        let y_of = |lat: f64| {
            // On the central meridian y = ρ0 − ρ(φ): find it by bisection on the inverse.
            let (mut lo, mut hi) = (-4.0e6, 6.0e6);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if conus.inverse(0.0, mid).0.to_degrees() < lat {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            0.5 * (lo + hi)
        };
        let ([sx, sy], skew) = conus.axis_scales(0.0, y_of(45.5));
        assert!(
            (sx - 1.0).abs() < 1e-9 && (sy - 1.0).abs() < 1e-9,
            "{sx} {sy}"
        );
        assert!(skew.abs() < 1e-9);
        // Between them the scale along the parallel is Snyder's (14-7), k = ρn / (a·m).
        let ([sx, sy], _) = conus.axis_scales(0.0, y_of(37.5));
        let (phi, [p1, p2]) = (37.5f64.to_radians(), [29.5f64, 45.5].map(f64::to_radians));
        let n = (el.m(p1).powi(2) - el.m(p2).powi(2)) / (el.q(p2) - el.q(p1));
        let c = el.m(p1).powi(2) + n * el.q(p1);
        let k = (c - n * el.q(phi)).sqrt() / el.m(phi);
        assert!(
            k < 0.995 && (1.0 / sx - k).abs() < 1e-9,
            "{} against {k}",
            1.0 / sx
        );
        assert!((sx * sy - 1.0).abs() < 1e-9, "{sx} · {sy}");
        // Off the central meridian the grid is turned against the parallels, and the
        // axes' ground lengths still span unit area with their angle.
        let ([sx, sy], skew) = conus.axis_scales(2.0e6, 1.5e6);
        let area = sx * sy * (1.0 - skew * skew).sqrt();
        assert!((area - 1.0).abs() < 1e-8, "{area}");
        // LAEA is true to scale at its centre, the pole included, and equal area
        // everywhere.
        for code in [3035, 6931, 3408] {
            let projection = EqualArea::of_epsg(code).unwrap();
            let [fe, fn_] = match &projection {
                EqualArea::Azimuthal {
                    false_easting_northing,
                    ..
                } => *false_easting_northing,
                _ => unreachable!(),
            };
            let ([sx, sy], skew) = projection.axis_scales(fe, fn_);
            // The spherical EASE grid keeps areas on its sphere, not on WGS 84: there
            // within 1 %.
            let tolerance = if code == 3408 { 1e-2 } else { 1e-8 };
            assert!(
                (sx - 1.0).abs() < tolerance && (sy - 1.0).abs() < tolerance,
                "{code}: {sx} {sy}"
            );
            assert!(skew.abs() < 1e-8, "{code}: {skew}");
            let ([sx, sy], skew) = projection.axis_scales(fe + 1.5e6, fn_ - 1.0e6);
            let area = sx * sy * (1.0 - skew * skew).sqrt();
            assert!((area - 1.0).abs() < tolerance, "{code}: {area}");
            assert!(sx > 1.0 + 1e-3 || sy > 1.0 + 1e-3, "{code}: {sx} {sy}");
        }
    }
}
