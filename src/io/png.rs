//! PNG files (previews and reports), written atomically.

use std::path::Path;

use image::ImageEncoder;
use image::codecs::png::PngEncoder;

use super::fs::write_atomic;
use crate::error::{Error, Result};

/// An 8-bit RGB picture, row by row from the top.
#[derive(Debug, Clone, PartialEq)]
pub struct Rgb {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<u8>,
}

impl Rgb {
    pub fn new(width: u32, height: u32) -> Self {
        Rgb {
            width,
            height,
            pixels: vec![0; width as usize * height as usize * 3],
        }
    }

    pub fn put(&mut self, x: u32, y: u32, colour: [u8; 3]) {
        let i = (y as usize * self.width as usize + x as usize) * 3;
        self.pixels[i..i + 3].copy_from_slice(&colour);
    }

    pub fn get(&self, x: u32, y: u32) -> [u8; 3] {
        let i = (y as usize * self.width as usize + x as usize) * 3;
        [self.pixels[i], self.pixels[i + 1], self.pixels[i + 2]]
    }
}

pub fn write_png(path: &Path, picture: &Rgb) -> Result<()> {
    write_atomic(path, |out| {
        PngEncoder::new(out)
            .write_image(
                &picture.pixels,
                picture.width,
                picture.height,
                image::ExtendedColorType::Rgb8,
            )
            .map_err(|e| Error::Failed(format!("encoding {}: {e}", path.display())))
    })
}

pub fn read_png(path: &Path) -> Result<Rgb> {
    let img = image::ImageReader::open(path)
        .map_err(|e| Error::input(path, e.to_string()))?
        .with_guessed_format()
        .map_err(|e| Error::input(path, e.to_string()))?
        .decode()
        .map_err(|e| Error::input(path, format!("not a readable image: {e}")))?
        .to_rgb8();
    Ok(Rgb {
        width: img.width(),
        height: img.height(),
        pixels: img.into_raw(),
    })
}
