//! The CRSs that formats name by their datum and UTM zone rather than in WKT (ERDAS
//! Imagine's projection parameters, ENVI's `map info`): geographic and UTM on WGS 84,
//! NAD83 and NAD27, as the EPSG GeoKeys GDAL would write for them.

/// Where a named CRS's coordinates lie.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Named {
    /// Longitude and latitude.
    Geographic,
    /// A UTM zone (1 to 60), north or south.
    Utm { zone: u16, north: bool },
}

/// The GeoKeys of `crs` on the datum named `datum` (`WGS 84`, `WGS-84`, `NAD83`,
/// `North America 1983`, `North_American_1927`...); `None` for another datum or a
/// zone EPSG does not define.
pub(crate) fn geokeys(crs: Named, datum: &str) -> Option<Vec<u16>> {
    let datum: String = datum
        .chars()
        .filter(char::is_ascii_alphanumeric)
        .collect::<String>()
        .to_ascii_uppercase();
    let family = match datum.as_str() {
        "WGS84" => 0,
        "NAD83" | "NORTHAMERICAN1983" | "NORTHAMERICA1983" => 1,
        "NAD27" | "NORTHAMERICAN1927" | "NORTHAMERICA1927" => 2,
        _ => return None,
    };
    let (projected, code) = match crs {
        Named::Geographic => (false, [4326, 4269, 4267][family]),
        Named::Utm { zone, north } => match (family, north, zone) {
            (_, _, 0) | (_, _, 61..) => return None,
            (0, true, _) => (true, 32600 + zone),
            (0, false, _) => (true, 32700 + zone),
            (1, true, ..=23) => (true, 26900 + zone),
            (2, true, ..=22) => (true, 26700 + zone),
            _ => return None,
        },
    };
    Some(epsg_geokeys(code, projected))
}

/// The GeoKeys of EPSG CRS `code`, projected or geographic, as GDAL writes them.
pub(crate) fn epsg_geokeys(code: u16, projected: bool) -> Vec<u16> {
    let mut keys = vec![1, 1, 0, 2, 1024, 0, 1, if projected { 1 } else { 2 }];
    keys.extend([if projected { 3072 } else { 2048 }, 0, 1, code]);
    keys
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn datums_and_zones_name_their_epsg_codes() {
        let code = |crs, datum| geokeys(crs, datum).map(|keys| keys[11]);
        let utm = |zone, north| Named::Utm { zone, north };
        assert_eq!(code(utm(16, true), "WGS 84"), Some(32616));
        assert_eq!(code(utm(33, false), "WGS-84"), Some(32733));
        assert_eq!(code(utm(15, true), "North America 1983"), Some(26915));
        assert_eq!(code(utm(17, true), "NAD27"), Some(26717));
        assert_eq!(code(Named::Geographic, "North_American_1983"), Some(4269));
        assert_eq!(code(Named::Geographic, "WGS84"), Some(4326));
        assert_eq!(code(utm(30, true), "NAD83"), None);
        assert_eq!(code(utm(61, true), "WGS 84"), None);
        assert_eq!(code(Named::Geographic, "ED50"), None);
    }
}
