//! Lengths of a degree on the WGS 84 ellipsoid, so that rasters in geographic
//! coordinates (EPSG:4326 and its kin) are measured in metres.

/// WGS 84 semi-major axis (m) and first eccentricity squared.
const A: f64 = 6_378_137.0;
const E2: f64 = 6.694_379_990_141_3e-3;

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

#[cfg(test)]
mod tests {
    use super::*;

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
