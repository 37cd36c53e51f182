//! Image files and image metrics: linear float EXR (the `image` crate's OpenEXR codec), sRGB PNG
//! previews, relative MSE and LDR-FLIP (`nv-flip`, NVIDIA's reference implementation).
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("{path}: {source}")]
    Codec {
        path: PathBuf,
        source: image::ImageError,
    },
    #[error("{path}: {what}")]
    Content { path: PathBuf, what: String },
    #[error("images differ in size: reference {0}x{1}, test {2}x{3}")]
    Size(u32, u32, u32, u32),
}

/// A linear RGB float image, row-major, y down.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
}

impl RgbImage {
    pub fn new(width: u32, height: u32, pixels: Vec<[f32; 3]>) -> Self {
        assert_eq!(pixels.len(), width as usize * height as usize);
        Self {
            width,
            height,
            pixels,
        }
    }

    /// The image box-filtered over `s` x `s` pixels: each output pixel the mean of its block (the
    /// reference's pixel, the integral over its area, where the blocks are a pixel's samples). The
    /// size must be a multiple of `s` (a supersampled frame's is).
    pub fn downsampled(&self, s: u32) -> Self {
        assert!(
            s >= 1 && self.width.is_multiple_of(s) && self.height.is_multiple_of(s),
            "{}x{} is not a multiple of {s}",
            self.width,
            self.height
        );
        let (w, h) = (self.width / s, self.height / s);
        let mut pixels = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                let mut sum = [0.0f64; 3];
                for sy in 0..s {
                    let row = ((y * s + sy) * self.width + x * s) as usize;
                    for p in &self.pixels[row..row + s as usize] {
                        for c in 0..3 {
                            sum[c] += p[c] as f64;
                        }
                    }
                }
                let n = (s * s) as f64;
                pixels.push(sum.map(|v| (v / n) as f32));
            }
        }
        Self::new(w, h, pixels)
    }

    /// The first non-finite pixel, as (x, y).
    pub fn first_non_finite(&self) -> Option<(u32, u32)> {
        self.first(|c| !c.is_finite())
    }

    /// The first pixel with a negative channel (not radiance), as (x, y).
    pub fn first_negative(&self) -> Option<(u32, u32)> {
        self.first(|c| c < 0.0)
    }

    fn first(&self, bad: impl Fn(f32) -> bool) -> Option<(u32, u32)> {
        self.pixels
            .iter()
            .position(|p| p.iter().any(|&c| bad(c)))
            .map(|i| (i as u32 % self.width, i as u32 / self.width))
    }
}

/// Pixel-wise sum (combined = direct + indirect).
pub fn add(a: &[[f32; 3]], b: &[[f32; 3]]) -> Vec<[f32; 3]> {
    a.iter()
        .zip(b)
        .map(|(x, y)| [x[0] + y[0], x[1] + y[1], x[2] + y[2]])
        .collect()
}

fn codec(path: &Path) -> impl FnOnce(image::ImageError) -> ImageError + '_ {
    move |source| ImageError::Codec {
        path: path.to_path_buf(),
        source,
    }
}

pub fn write_exr(path: &Path, img: &RgbImage) -> Result<(), ImageError> {
    let flat: Vec<f32> = img.pixels.iter().flatten().copied().collect();
    let buf = image::Rgb32FImage::from_raw(img.width, img.height, flat).expect("sized");
    buf.save_with_format(path, image::ImageFormat::OpenExr)
        .map_err(codec(path))
}

pub fn read_exr(path: &Path) -> Result<RgbImage, ImageError> {
    let img = image::open(path).map_err(codec(path))?.to_rgb32f();
    let (w, h) = img.dimensions();
    let pixels = img
        .into_raw()
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    Ok(RgbImage::new(w, h, pixels))
}

/// sRGB encoding of a linear value clamped to [0, 1].
pub fn srgb_encode(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// 8-bit sRGB bytes (RGB) of a linear image clamped to [0, 1].
pub fn srgb8(img: &RgbImage) -> Vec<u8> {
    img.pixels
        .iter()
        .flatten()
        .map(|&c| (srgb_encode(c) * 255.0 + 0.5) as u8)
        .collect()
}

pub fn write_png_preview(path: &Path, img: &RgbImage) -> Result<(), ImageError> {
    let buf = image::RgbImage::from_raw(img.width, img.height, srgb8(img)).expect("sized");
    buf.save_with_format(path, image::ImageFormat::Png)
        .map_err(codec(path))
}

/// Writes `NAME.exr` and `NAME.png` into `dir`.
pub fn write_pair(dir: &Path, name: &str, img: &RgbImage) -> Result<(), ImageError> {
    write_exr(&dir.join(format!("{name}.exr")), img)?;
    write_png_preview(&dir.join(format!("{name}.png")), img)
}

/// The four images of a frame — direct, indirect, combined, ao — as EXR + PNG preview in `dir`.
pub fn write_frame(dir: &Path, images: [&RgbImage; 4]) -> Result<(), ImageError> {
    for (name, img) in ["direct", "indirect", "combined", "ao"]
        .into_iter()
        .zip(images)
    {
        write_pair(dir, name, img)?;
    }
    Ok(())
}

/// Result of [`compare`].
#[derive(Clone, Debug)]
pub struct Comparison {
    /// Mean over pixels and channels of (t - r)^2 / (r^2 + 0.01).
    pub rel_mse: f64,
    /// Mean LDR-FLIP at 67 pixels per degree of both images clamped to [0, 1], sRGB-encoded.
    pub flip_mean: f32,
    /// FLIP error map coloured with the magma map (RGB8), for a heat-map PNG.
    pub heatmap: Vec<u8>,
    /// Sum of the test image's channels over the reference's (1 = the same energy; NaN when the
    /// reference is black): the bias FLIP and MSE do not show as a direction.
    pub energy_ratio: f64,
}

fn check_finite(path: &Path, img: &RgbImage) -> Result<(), ImageError> {
    match img.first_non_finite() {
        Some((x, y)) => Err(ImageError::Content {
            path: path.to_path_buf(),
            what: format!("non-finite pixel at ({x}, {y})"),
        }),
        None => Ok(()),
    }
}

pub fn relative_mse(reference: &RgbImage, test: &RgbImage) -> f64 {
    let n = reference.pixels.len() * 3;
    reference
        .pixels
        .iter()
        .flatten()
        .zip(test.pixels.iter().flatten())
        .map(|(&r, &t)| {
            let (r, t) = (r as f64, t as f64);
            (t - r) * (t - r) / (r * r + 0.01)
        })
        .sum::<f64>()
        / n.max(1) as f64
}

/// Compare `test` against `reference` (paths name the images in errors).
pub fn compare(
    reference: &RgbImage,
    reference_path: &Path,
    test: &RgbImage,
    test_path: &Path,
) -> Result<Comparison, ImageError> {
    check_finite(reference_path, reference)?;
    check_finite(test_path, test)?;
    if (reference.width, reference.height) != (test.width, test.height) {
        return Err(ImageError::Size(
            reference.width,
            reference.height,
            test.width,
            test.height,
        ));
    }
    let r8 =
        nv_flip::FlipImageRgb8::with_data(reference.width, reference.height, &srgb8(reference));
    let t8 = nv_flip::FlipImageRgb8::with_data(test.width, test.height, &srgb8(test));
    let error = nv_flip::flip(r8, t8, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let flip_mean = nv_flip::FlipPool::from_image(&error).mean();
    let heatmap = error.apply_color_lut(&nv_flip::magma_lut()).to_vec();
    let energy = |img: &RgbImage| {
        img.pixels
            .iter()
            .map(|p| p[0] as f64 + p[1] as f64 + p[2] as f64)
            .sum::<f64>()
    };
    Ok(Comparison {
        rel_mse: relative_mse(reference, test),
        flip_mean,
        heatmap,
        energy_ratio: energy(test) / energy(reference),
    })
}

pub fn write_heatmap(path: &Path, width: u32, height: u32, rgb8: &[u8]) -> Result<(), ImageError> {
    let buf = image::RgbImage::from_raw(width, height, rgb8.to_vec()).expect("sized");
    buf.save_with_format(path, image::ImageFormat::Png)
        .map_err(codec(path))
}

#[cfg(test)]
mod tests {
    use super::RgbImage;

    #[test]
    fn downsampling_averages_each_block_exactly() {
        // 4 x 2 pixels whose values are their indices: 2 x 2 blocks average to exact halves.
        let px: Vec<[f32; 3]> = (0..8).map(|i| [i as f32, 2.0 * i as f32, 1.0]).collect();
        let img = RgbImage::new(4, 2, px);
        let d = img.downsampled(2);
        assert_eq!((d.width, d.height), (2, 1));
        // Block (0, 0): pixels 0, 1, 4, 5 -> 2.5; block (1, 0): 2, 3, 6, 7 -> 4.5.
        assert_eq!(d.pixels, vec![[2.5, 5.0, 1.0], [4.5, 9.0, 1.0]]);
        assert_eq!(img.downsampled(1), img);
    }

    #[test]
    #[should_panic(expected = "not a multiple")]
    fn downsampling_refuses_a_size_that_is_not_a_multiple() {
        RgbImage::new(3, 2, vec![[0.0; 3]; 6]).downsampled(2);
    }
}
