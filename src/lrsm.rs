//! Layered reflective shadow maps (Sugihara et al. 2014): the host side of the LRSM kernels — the static
//! partition's layout, checked at the API boundary, and synthetic RSMs for tests and benchmarks.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use thiserror::Error;
use vxgi_cpu_mirror::morton;

/// Most layers one LRSM may have (the paper uses 4-6; 64 keeps per-invocation work bounded).
pub const MAX_LAYERS: u32 = 64;

#[derive(Debug, Error, PartialEq)]
pub enum LrsmError {
    #[error("RSM side {0} must be a power of two >= 2 (the LRSM is the RSM at half width and height, in Morton order)")]
    RsmSize(u32),
    #[error("{depth_splits} depth and {normal_splits} normal partitions give {layers} layers; at most {MAX_LAYERS} fit the layer array")]
    TooManyLayers {
        depth_splits: u32,
        normal_splits: u32,
        layers: u32,
    },
    #[error("{layers} layers of {texels} texels need {bytes} bytes per stream, past max_storage_buffer_binding_size = {limit}")]
    LayerArrayTooLarge {
        layers: u32,
        texels: u64,
        bytes: u64,
        limit: u64,
    },
    #[error("overlap {overlap} must be finite, >= 0 and at most one depth slice ({slice})")]
    Overlap { overlap: f32, slice: f32 },
    #[error("RSM texel {index} (x={x}, y={y}) holds a non-finite {what}: {value}")]
    NonFinite {
        index: usize,
        x: u32,
        y: u32,
        what: &'static str,
        value: f32,
    },
    #[error("RSM streams disagree in length: {radiance} radiance, {normal} normal, {depth} depth texels for side {side}")]
    Length {
        radiance: usize,
        normal: usize,
        depth: usize,
        side: u32,
    },
}

/// The static partition (section 4.3): `depth_splits` (a) and `normal_splits` (b) give (a+1) depth slices
/// x (b+1) <n.l> slices; neighbouring depth slices overlap by `overlap` (delta of eq. 15).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PartitionConfig {
    pub rsm_side: u32,
    pub depth_splits: u32,
    pub normal_splits: u32,
    pub overlap: f32,
    /// Each RSM texel weighs `1 / <n.l>` in the radiance and moment streams (`lrsm_area_weights`;
    /// see kernels/lrsm_partition.wgsl).
    pub area_weights: bool,
}

impl PartitionConfig {
    /// The paper's partition for Sibenik and Sponza: 2 x 2 layers (one depth and one <n.l> split),
    /// overlap 0.05 (the `[render]` default), Algorithm 1's opacity-weighted layers.
    pub fn two_by_two(rsm_side: u32) -> Self {
        Self {
            rsm_side,
            depth_splits: 1,
            normal_splits: 1,
            overlap: 0.05,
            area_weights: false,
        }
    }

    pub fn depth_slices(&self) -> u32 {
        self.depth_splits + 1
    }
    pub fn normal_slices(&self) -> u32 {
        self.normal_splits + 1
    }
    pub fn layers(&self) -> u32 {
        self.depth_slices() * self.normal_slices()
    }
    /// Texels per layer at LRSM level 0.
    pub fn layer_texels(&self) -> u64 {
        (self.rsm_side as u64 / 2).pow(2)
    }

    /// Refuse what the kernels cannot hold or would compute nonsense from.
    pub fn validate(&self, max_storage_binding: u64) -> Result<(), LrsmError> {
        if self.rsm_side < 2 || !self.rsm_side.is_power_of_two() {
            return Err(LrsmError::RsmSize(self.rsm_side));
        }
        let layers = self.depth_slices() as u64 * self.normal_slices() as u64;
        if layers > MAX_LAYERS as u64 {
            return Err(LrsmError::TooManyLayers {
                depth_splits: self.depth_splits,
                normal_splits: self.normal_splits,
                layers: layers.min(u32::MAX as u64) as u32,
            });
        }
        let bytes = layers * self.layer_texels() * crate::kernels::lrsm_prefilter::TEXEL_BYTES;
        if bytes > max_storage_binding {
            return Err(LrsmError::LayerArrayTooLarge {
                layers: layers as u32,
                texels: self.layer_texels(),
                bytes,
                limit: max_storage_binding,
            });
        }
        let slice = 1.0 / self.depth_slices() as f32;
        if !(self.overlap >= 0.0 && self.overlap <= slice) {
            return Err(LrsmError::Overlap {
                overlap: self.overlap,
                slice,
            });
        }
        Ok(())
    }

    /// `(zmin, zmax, 1 / (zmax - zmin), 0)` per depth slice: slice d is `[d, d+1] / slices` widened by
    /// overlap/2 on each side, and by a full overlap at 0 and 1 so that layer_decay is 1 at the ends
    /// of the depth range (no neighbour layer there to blend with).
    pub fn depth_ranges(&self) -> Vec<[f32; 4]> {
        let n = self.depth_slices();
        let h = self.overlap * 0.5;
        (0..n)
            .map(|d| {
                let lo = if d == 0 {
                    -self.overlap
                } else {
                    d as f32 / n as f32 - h
                };
                let hi = if d + 1 == n {
                    1.0 + self.overlap
                } else {
                    (d + 1) as f32 / n as f32 + h
                };
                [lo, hi, 1.0 / (hi - lo), 0.0]
            })
            .collect()
    }
}

/// A reflective shadow map (side `side`, 2D Morton order): see `kernels/lrsm_partition.wgsl`.
#[derive(Clone, Debug)]
pub struct Rsm {
    pub side: u32,
    pub radiance: Vec<[f32; 4]>,
    pub normal: Vec<[f32; 4]>,
    pub depth: Vec<f32>,
}

impl Rsm {
    /// NaN or infinity anywhere is an error naming the texel (the kernels' arithmetic is only
    /// specified for finite values).
    pub fn validate(&self) -> Result<(), LrsmError> {
        let n = (self.side as usize).pow(2);
        if self.radiance.len() != n || self.normal.len() != n || self.depth.len() != n {
            return Err(LrsmError::Length {
                radiance: self.radiance.len(),
                normal: self.normal.len(),
                depth: self.depth.len(),
                side: self.side,
            });
        }
        let bad = |index: usize, what: &'static str, value: f32| {
            let [x, y] = morton::decode2(index as u32);
            Err(LrsmError::NonFinite {
                index,
                x,
                y,
                what,
                value,
            })
        };
        for i in 0..n {
            if let Some(v) = self.radiance[i].iter().find(|v| !v.is_finite()) {
                return bad(i, "radiance", *v);
            }
            if let Some(v) = self.normal[i].iter().find(|v| !v.is_finite()) {
                return bad(i, "normal", *v);
            }
            if !self.depth[i].is_finite() {
                return bad(i, "depth", self.depth[i]);
            }
        }
        Ok(())
    }
}

/// A synthetic RSM as a spot light straight down (+z light-space depth) would see it: a tilted floor,
/// a raised box (depth and normal discontinuities), a bump, background texels, and a sprinkling of hard
/// values (depths exactly on slice bounds, <n.l> exactly on slice bounds, 0, 1, back-facing).
pub fn synthetic_rsm(side: u32, config: &PartitionConfig, seed: u64) -> Rsm {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = (side as usize).pow(2);
    let ranges = config.depth_ranges();
    let mut rsm = Rsm {
        side,
        radiance: vec![[0.0; 4]; n],
        normal: vec![[0.0; 4]; n],
        depth: vec![0.0; n],
    };
    let tilt: f32 = rng.random_range(-0.3..0.3);
    for i in 0..n {
        let [x, y] = morton::decode2(i as u32);
        let (u, v) = (
            (x as f32 + 0.5) / side as f32,
            (y as f32 + 0.5) / side as f32,
        );
        let (mut z, mut nrm) = (
            0.7 + tilt * (u - 0.5),
            glam::Vec3::new(-tilt, 0.0, 1.0).normalize(),
        );
        if (0.3..0.6).contains(&u) && (0.2..0.5).contains(&v) {
            z = 0.35; // box top
            nrm = glam::Vec3::Z;
        }
        let (du, dv) = (u - 0.75, v - 0.75);
        if du * du + dv * dv < 0.02 {
            let h = (0.02 - du * du - dv * dv).sqrt();
            z -= h;
            nrm = glam::Vec3::new(du, dv, h).normalize();
        }
        let mut ndotl = nrm.z;
        let mut covered = !(u > 0.95 && v > 0.9);
        match rng.random_range(0..24) {
            0 => z = ranges[rng.random_range(0..ranges.len())][rng.random_range(0..2)],
            1 => {
                ndotl = rng.random_range(0..=config.normal_slices()) as f32
                    / config.normal_slices() as f32
            }
            2 => z = [0.0, 1.0][rng.random_range(0..2)],
            3 => ndotl = -0.2,
            4 => covered = false,
            _ => {}
        }
        let albedo = if u < 0.5 {
            [0.8, 0.2, 0.2]
        } else {
            [0.2, 0.8, 0.2]
        };
        let ld = 3.0 * ndotl.max(0.0) / std::f32::consts::PI;
        rsm.radiance[i] = [
            albedo[0] * ld,
            albedo[1] * ld,
            albedo[2] * ld,
            if covered { 1.0 } else { 0.0 },
        ];
        rsm.normal[i] = [nrm.x, nrm.y, nrm.z, ndotl];
        rsm.depth[i] = if covered { z } else { 1.0 };
    }
    rsm
}

/// Bytes of the LRSM for `config`: three streams of four binary16 values per layer texel over the whole
/// mip chain (the paper's Table 1's 16-bit channels).
pub fn lrsm_bytes(config: &PartitionConfig) -> u64 {
    lrsm_texels(config) * 3 * crate::kernels::lrsm_prefilter::TEXEL_BYTES
}

/// Texels of one view's LRSM stream: every layer over the whole mip chain, level by level (level k
/// holds every layer's `(rsm_side / 2 >> k)^2` texels). A view's streams start at its index times this.
pub fn lrsm_texels(config: &PartitionConfig) -> u64 {
    let side0 = (config.rsm_side / 2) as u64;
    let texels: u64 = (0..=side0.trailing_zeros())
        .map(|k| (side0 >> k).pow(2))
        .sum();
    texels * config.layers() as u64
}

/// One light view of the lrsm pipeline: the G-buffer frame its RSM is ray-cast with (gbuffer.wgsl) and
/// the view the RSM and the gather kernels project with.
#[derive(Clone, Copy, Debug)]
pub struct LightView {
    pub frame: vxgi_cpu_mirror::gbuffer::Frame,
    pub view: vxgi_cpu_mirror::reflective_shadow_map::GpuView,
}

/// Whether `light` casts light (gets light views): a nonzero intensity.
pub fn casts(light: &vxgi_cpu_mirror::direct_light::GpuLight) -> bool {
    light.intensity[..3] != [0.0; 3]
}

/// The views of `lights` (scene `bounds`, G-buffer `eps` as the camera frame's eye.w): a spot light
/// whose cone is at most 60 degrees wide (half-angle) gets one view along its axis, fitted to the cone;
/// a point light, or a wider spot, six 90-degree cube faces (+x, -x, +y, -y, +z, -z); a directional
/// light one orthographic view of the whole bounds along its direction. Depth runs from the light (near
/// 0; a directional light's image plane sits outside the bounds) to the farthest corner (far). `info[2]` (the view's first LRSM
/// texel) is left 0 for the caller.
pub fn light_views(
    lights: &[vxgi_cpu_mirror::direct_light::GpuLight],
    bounds: (glam::Vec3, glam::Vec3),
    rsm_side: u32,
    eps: f32,
) -> Result<Vec<LightView>, LrsmError> {
    use glam::Vec3;
    use vxgi_cpu_mirror::direct_light::{DIRECTIONAL, SPOT};
    let mut views = Vec::new();
    for (i, l) in lights.iter().enumerate() {
        // A light of zero intensity casts nothing: no view (`crate::plan::views_of`).
        if !casts(l) {
            continue;
        }
        if l.position[3] == DIRECTIONAL {
            views.push(orthographic_view(l, i, lights.len(), bounds, rsm_side, eps));
            continue;
        }
        let eye = Vec3::new(l.position[0], l.position[1], l.position[2]);
        let far = (0..8)
            .map(|c| {
                let corner = Vec3::new(
                    if c & 1 == 0 { bounds.0.x } else { bounds.1.x },
                    if c & 2 == 0 { bounds.0.y } else { bounds.1.y },
                    if c & 4 == 0 { bounds.0.z } else { bounds.1.z },
                );
                (corner - eye).length()
            })
            .fold(0.0f32, f32::max)
            * 1.001
            + 1e-6;
        let cos_cone = l.direction[3];
        let axes: Vec<(Vec3, f32)> = if l.position[3] == SPOT && cos_cone >= 0.5 {
            let tan = (1.0 - cos_cone * cos_cone).max(0.0).sqrt() / cos_cone;
            vec![(
                Vec3::new(l.direction[0], l.direction[1], l.direction[2]),
                tan.max(1e-3),
            )]
        } else {
            [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
                .into_iter()
                .map(|a| (a, 1.0))
                .collect()
        };
        for (forward, tan) in axes {
            views.push(view_along(
                eye,
                forward.normalize(),
                tan,
                far,
                [rsm_side, i as u32, lights.len() as u32, 0],
                eps,
            ));
        }
    }
    Ok(views)
}

/// The view from `eye` along the unit vector `forward`: its image plane spans `half` on each
/// side at unit distance (perspective: the tangent of the half-angle) or in world units
/// (orthographic), depth runs to `far`. `at` = [RSM side, light index, light count, 1 where
/// orthographic else 0]. The basis's `up` helper is +z for a view within 26 degrees of the y axis,
/// else +y.
fn view_along(
    eye: glam::Vec3,
    forward: glam::Vec3,
    half: f32,
    far: f32,
    at: [u32; 4],
    eps: f32,
) -> LightView {
    use glam::Vec3;
    let [rsm_side, index, light_count, orthographic] = at;
    let helper = if forward.y.abs() > 0.9 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    let right = forward.cross(helper).normalize();
    let up = right.cross(forward);
    let v4 = |v: Vec3, w: f32| [v.x, v.y, v.z, w];
    LightView {
        frame: vxgi_cpu_mirror::gbuffer::Frame {
            eye: v4(eye, eps),
            forward: v4(forward, 0.0),
            right: v4(right * half, 0.0),
            up: v4(up * half, 0.0),
            size: [rsm_side, rsm_side, light_count, orthographic],
        },
        view: vxgi_cpu_mirror::reflective_shadow_map::GpuView {
            eye: v4(eye, 0.0),
            forward: v4(forward, 1.0 / far),
            right: v4(right / half, (rsm_side / 2) as f32 / (2.0 * half)),
            up: v4(up / half, 0.0),
            info: [rsm_side, index, 0, orthographic],
        },
    }
}

/// A directional light's view: orthographic along its direction, square, covering the bounds' bounding
/// sphere, the image plane one radius (plus a margin) before the centre.
pub fn orthographic_view(
    l: &vxgi_cpu_mirror::direct_light::GpuLight,
    index: usize,
    light_count: usize,
    bounds: (glam::Vec3, glam::Vec3),
    rsm_side: u32,
    eps: f32,
) -> LightView {
    use glam::Vec3;
    let forward = Vec3::new(l.direction[0], l.direction[1], l.direction[2]).normalize();
    let centre = (bounds.0 + bounds.1) * 0.5;
    let radius = (bounds.1 - bounds.0).length() * 0.5 * 1.001 + 1e-6;
    let eye = centre - forward * (radius * 1.01);
    let far = radius * 2.02;
    view_along(
        eye,
        forward,
        radius,
        far,
        [rsm_side, index as u32, light_count as u32, 1],
        eps,
    )
}
