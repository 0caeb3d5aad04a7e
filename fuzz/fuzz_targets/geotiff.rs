//! The GeoTIFF reader on arbitrary files: every compression it decodes (LZW, Deflate,
//! PackBits, ZSTD, LZMA, JPEG, LERC, WebP, JPEG XL, `NBITS` packings), tiles, strips and
//! GeoKeys. Errors naming the file, never panics.
#![no_main]

use libfuzzer_sys::fuzz_target;

/// Cells the fuzzer may declare: a damaged header can claim any size, and a raster of
/// billions of cells is refused by memory, not by the reader's checks, so the fuzzer
/// would report every such input as out of memory.
const MAX_CELLS: u64 = 1 << 24;

fn declared_cells(data: &[u8]) -> Option<u64> {
    let mut decoder = tiff::decoder::Decoder::new(std::io::Cursor::new(data)).ok()?;
    let (width, height) = decoder.dimensions().ok()?;
    let samples = decoder
        .find_tag_unsigned::<u16>(tiff::tags::Tag::SamplesPerPixel)
        .ok()
        .flatten()
        .unwrap_or(1);
    Some(u64::from(width) * u64::from(height) * u64::from(samples.max(1)))
}

fuzz_target!(|data: &[u8]| {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(imitate::error::install_panic_hook);
    if declared_cells(data).is_some_and(|cells| cells > MAX_CELLS) {
        return;
    }
    let dir = std::env::temp_dir().join(format!("imitate-fuzz-geotiff-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("fuzzed.tif");
    std::fs::write(&path, data).unwrap();
    if let Err(e) = imitate::io::geotiff::read_geotiff(&path, "m") {
        assert!(e.to_string().contains("fuzzed.tif"), "{e}");
    }
});
