//! Pictures of strands for the docs: particles joined into lines, seen along head z, drawn
//! into an RGB buffer and written as PNG.

use hair_sim::prelude::*;
use std::path::{Path, PathBuf};

/// An RGB picture of panels side by side in rows, each showing the same square of the
/// x–y plane.
pub struct StrandPicture {
    width: u32,
    height: u32,
    pixels: Vec<[u8; 3]>,
    /// Pixels per metre, and the x–y plane's point at each panel's top-left corner.
    scale: f32,
    corner: Vec3,
    panel: u32,
}

impl StrandPicture {
    /// `columns` × `rows` panels of `panel` pixels a side, each showing `size` metres of
    /// the x–y plane from `corner` (its top-left), on white.
    pub fn new(columns: u32, rows: u32, panel: u32, corner: Vec3, size: f32) -> Self {
        let (width, height) = (columns * panel, rows * panel);
        let pixels = vec![[255; 3]; (width * height) as usize];
        StrandPicture { width, height, pixels, scale: panel as f32 / size, corner, panel }
    }

    /// Draws each strand of `n` particles in `positions` into panel (`column`, `row`) as
    /// a line through its particles, in `colour`.
    pub fn strands(&mut self, (column, row): (u32, u32), positions: &[Vec3], n: usize, colour: [u8; 3]) {
        let origin = (column * self.panel, row * self.panel);
        for strand in positions.chunks_exact(n) {
            for pair in strand.windows(2) {
                let (a, b) = (self.to_panel(pair[0]), self.to_panel(pair[1]));
                // Enough dots that the line has no gaps.
                let dots = (a.0 - b.0).abs().max((a.1 - b.1).abs()).ceil().max(1.0) as usize;
                for k in 0..=dots {
                    let t = k as f32 / dots as f32;
                    let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
                    self.dot(origin, x, y, colour);
                }
            }
        }
    }

    fn to_panel(&self, p: Vec3) -> (f32, f32) {
        ((p.x - self.corner.x) * self.scale, (self.corner.y - p.y) * self.scale)
    }

    fn dot(&mut self, origin: (u32, u32), x: f32, y: f32, colour: [u8; 3]) {
        let limit = self.panel as f32;
        if !(x >= 0.0 && y >= 0.0 && x < limit && y < limit) {
            return;
        }
        let (px, py) = (origin.0 + x as u32, origin.1 + y as u32);
        self.pixels[(py * self.width + px) as usize] = colour;
    }

    /// Grey lines between the panels.
    fn frame(&mut self) {
        for y in 0..self.height {
            for x in 0..self.width {
                if x % self.panel == 0 || y % self.panel == 0 {
                    self.pixels[(y * self.width + x) as usize] = [160; 3];
                }
            }
        }
    }

    /// Writes it as `name.png` under the test's scratch folder, and returns the path.
    pub fn save(mut self, name: &str) -> PathBuf {
        self.frame();
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("hair-pictures");
        std::fs::create_dir_all(&dir).expect("a folder for the pictures");
        let path = dir.join(format!("{name}.png"));
        let file = std::io::BufWriter::new(std::fs::File::create(&path).expect("a picture file"));
        let mut encoder = png::Encoder::new(file, self.width, self.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().expect("a PNG header");
        writer.write_image_data(self.pixels.as_flattened()).expect("the PNG's pixels");
        path
    }
}
