//! The Parquet table readers on arbitrary files: maps, feature stacks, costmaps, paths
//! and users' demonstrations tables. Errors naming the file, never panics.
#![no_main]

use imitate::io::demo_tables::{Columns, read_demonstrations_table};
use imitate::io::tables::{read_costmap, read_features, read_map, read_paths};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // As the binary does: panics the readers catch on purpose (third-party decoders on
    // damaged files) are errors; any other panic still aborts for the fuzzer.
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(imitate::error::install_panic_hook);
    let path = std::env::temp_dir().join(format!("imitate-fuzz-table-{}.parquet", std::process::id()));
    std::fs::write(&path, data).unwrap();
    let _ = read_map(&path);
    let _ = read_features(&path);
    let _ = read_costmap(&path);
    let _ = read_paths(&path);
    let _ = read_demonstrations_table(&path, &Columns::default(), Some("map"));
});
