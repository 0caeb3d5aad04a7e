//! How wide a neighbourhood each feature reads, told from its name. Names are the
//! features' contract (the same on every map, stored with every stack and model), so
//! a learner that only has a stack read back from disk can still tell the cell's own
//! values from regional summaries.

/// Whether the feature called `name` is a distance (to a class, a quantile's cells or
/// a threshold's): its values are lengths of paths of cell steps, each level a ring
/// around its target. (A product of features is not.)
pub fn is_distance(name: &str) -> bool {
    let op = name.rsplit_once('/').map_or(name, |(_, op)| op);
    !name.contains('*') && op.starts_with("distance_to_")
}

/// The scale of the feature called `name` in cells: half the side of the square of
/// cells it reads (0.5 for the cell alone, 1.5 for a 3 × 3 stencil or window), σ for a
/// Gaussian, and infinity for a distance (which may read the whole map). Lengths in
/// metres are converted with `cell_metres`. A name that no operator of this crate
/// makes (a column of the user's own table) is taken as the cell's own value.
pub fn scale_in_cells(name: &str, cell_metres: f64) -> f64 {
    if let Some((a, b)) = name.split_once('*') {
        return scale_in_cells(a, cell_metres).max(scale_in_cells(b, cell_metres));
    }
    let op = name.rsplit_once('/').map_or(name, |(_, op)| op);
    let number = |prefix: &str, suffix: &str| -> Option<f64> {
        op.strip_prefix(prefix)?.strip_suffix(suffix)?.parse().ok()
    };
    const CELL: f64 = 0.5;
    const STENCIL: f64 = 1.5;
    if is_distance(name) {
        f64::INFINITY
    } else if let Some(cells) = number("blur_", "c")
        .or_else(|| number("relief_", "c"))
        .or_else(|| number("contrast_", "c"))
    {
        cells
    } else if let Some(metres) = number("blur_", "m") {
        metres / cell_metres
    } else if let Some(window) = number("roughness_", "c") {
        window / 2.0
    } else if ["slope_deg", "aspect_deg", "gradient", "laplacian"].contains(&op) {
        STENCIL
    } else {
        CELL
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales_follow_the_operators_windows() {
        let scale = |name| scale_in_cells(name, 10.0);
        for (name, expected) in [
            ("band1/robust", 0.5),
            ("band1/above_q90", 0.5),
            ("nd(band1,band2)", 0.5),
            ("brightness", 0.5),
            ("bias", 0.5),
            ("elevation/nodata", 0.5),
            ("my_column", 0.5),
            ("band1/blur_1c", 1.0),
            ("band1/blur_2.5c", 2.5),
            ("band1/blur_30m", 3.0),
            ("elevation/slope_deg", 1.5),
            ("elevation/laplacian", 1.5),
            ("elevation/roughness_3c", 1.5),
            ("elevation/roughness_15c", 7.5),
            ("elevation/relief_16c", 16.0),
            ("band1/contrast_3c", 3.0),
            ("band1/robust*elevation/relief_6c", 6.0),
        ] {
            assert_eq!(scale(name), expected, "{name}");
        }
        assert_eq!(scale("band1/distance_to_above_q90_m"), f64::INFINITY);
        assert_eq!(scale("roads/distance_to_class_1_m"), f64::INFINITY);
    }

    #[test]
    fn distances_are_told_from_their_names() {
        assert!(is_distance("brightness/distance_to_above_q90_m"));
        assert!(is_distance("roads/distance_to_class_1_m"));
        assert!(!is_distance("band1/blur_3c"));
        assert!(!is_distance("band1/robust*roads/distance_to_class_1_m"));
    }
}
