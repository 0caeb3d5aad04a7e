//! The MCAP reader on arbitrary files: the streaming scan (records, chunks, their
//! claimed sizes and CRCs) decoding every message it meets, and the summary-based
//! inspect. Neither may panic, abort or allocate past its budget.
#![no_main]

use imitate::io::mcap::inspect::{Source, inspect};
use imitate::io::mcap::{Decoders, Event, scan};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // As the binary does: panics the readers catch on purpose (third-party decoders on
    // damaged files) are errors; any other panic still aborts for the fuzzer.
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(imitate::error::install_panic_hook);
    // The readers take paths, as users give them: one scratch file per process.
    let path = std::env::temp_dir().join(format!("imitate-fuzz-mcap-{}", std::process::id()));
    std::fs::write(&path, data).unwrap();
    let decoders = Decoders::default();
    let _ = scan(&path, |event| {
        if let Event::Message { channel, data, .. } = event {
            if let Ok(decoder) = decoders.get(channel) {
                let _ = decoder.decode(data);
            }
        }
        Ok(())
    });
    let _ = inspect(&path, Source::VerifiedSummary, true);
    let _ = inspect(&path, Source::Scan, false);
});
