//! Lengths of a degree on the WGS 84 ellipsoid, so that rasters in geographic
//! coordinates (EPSG:4326 and its kin) are measured in metres, and of a Web Mercator
//! metre (EPSG:3857), which is a ground metre only on the equator.

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
