//! Declaration of `kernels/screen_tiles.wgsl` (mirror: `vxgi_cpu_mirror::screen_tiles`): the work list
//! of 8x8 screen tiles holding a surface and the indirect arguments the cone passes are dispatched with.
//! Cases: empty, full and sparse G-buffers, sizes that are not multiples of 8, one-pixel images, NaN and
//! back-face normals.
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;
use vxgi_cpu_mirror::gbuffer::Frame;
use vxgi_cpu_mirror::screen_tiles::{list_len, tile_list, tiles_xy, HEADER};
use vxgi_harness::prelude::*;
use vxgi_harness::run::Pass;

vxgi_harness::bindings! {
    /// screen_tiles' bindings: the G-buffer's normals in, the tile list (header, then tiles) out.
    pub struct Io {
        inputs: {
            /// Only the size is read.
            frame: Block<Frame>,
            gb_normal: Vec<[f32; 4]>,
        }
        outputs: {
            // Integers and one comparison with 0 per pixel: exact, after sorting the appended tiles
            // (`canonicalise`).
            tile_list: Vec<u32> => Tolerance::Exact
        }
    }
}

pub static DECL: KernelDecl = vxgi_harness::kernel_decl!(
    "screen_tiles",
    includes: &[super::SCENE_TYPES],
    inputs: Io::INPUTS,
    outputs: Io::OUTPUTS,
    dispatch: DispatchRule::PerItem {
        what: "8x8 screen tile (one workgroup each)",
    },
    mirror: "vxgi_cpu_mirror::screen_tiles::tile_list",
    summary: "work list of the 8x8 screen tiles holding a surface + indirect dispatch arguments (empty tiles are not dispatched)",
);

/// The frame constants screen_tiles reads (only the size matters to it).
pub fn frame_of_size(width: u32, height: u32) -> Frame {
    Frame {
        size: [width, height, 0, 0],
        ..Default::default()
    }
}

/// The pass over every tile of a `width` x `height` image (the `tile_list` resource must start at 0).
pub fn pass(width: u32, height: u32) -> Pass {
    let (tx, ty) = tiles_xy(width, height);
    Pass::direct(DECL.name, DECL.entry, DECL.bind_by_name(), [tx, ty, 1])
}

/// The zeroed list buffer for a `width` x `height` image (usable as indirect arguments).
pub fn empty_list(width: u32, height: u32) -> HostResource {
    HostBuffer::zeroed(list_len(width, height) * 4, ScalarKind::U32).into()
}

/// A cone-pass case (`cone_trace::tracer_case`) dispatched over every tile of its image instead of its
/// list: what a plain dispatch runs, the rule's "off".
pub fn every_tile(case: &Case) -> Case {
    let frame: Frame =
        *bytemuck::from_bytes(&case.resources["frame"].buffer().expect("frame").bytes);
    let [w, h, ..] = frame.size;
    let mut all = case.clone();
    let surface = vec![[0.0, 0.0, 0.0, 1.0]; (w * h) as usize];
    let tiles = HostBuffer::of(&tile_list(&surface, w, h));
    all.resources.insert("tile_list".into(), tiles.into());
    all
}

pub fn case_for(normal: &[[f32; 4]], width: u32, height: u32, label: String, seed: u64) -> Case {
    let io = Io {
        frame: Block(frame_of_size(width, height)),
        gb_normal: normal.to_vec(),
        tile_list: vec![0; list_len(width, height)],
    };
    io.case(label, seed, vec![pass(width, height)])
}

/// Generated G-buffer normals: `fill` of the pixels are surface, in blobs (so some tiles are empty and
/// some partly covered), with back faces (w = -1) and NaN normals among them.
pub fn normals(seed: u64, index: usize, width: u32, height: u32, fill: f64) -> Vec<[f32; 4]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ (index as u64).wrapping_mul(0x9e37_79b9));
    let blobs: Vec<(f32, f32, f32)> = (0..8)
        .map(|_| {
            (
                rng.random_range(0.0..width as f32),
                rng.random_range(0.0..height as f32),
                rng.random_range(0.5..(width.max(height) as f32 * fill as f32 * 0.5 + 1.0)),
            )
        })
        .collect();
    (0..width * height)
        .map(|p| {
            let (x, y) = ((p % width) as f32, (p / width) as f32);
            let inside = fill >= 1.0
                || blobs
                    .iter()
                    .any(|&(cx, cy, r)| (x - cx).powi(2) + (y - cy).powi(2) <= r * r);
            if !inside || fill <= 0.0 {
                return [0.0; 4];
            }
            match rng.random_range(0..16) {
                0 => [0.0, 0.0, 1.0, -1.0],
                1 => [f32::NAN; 4],
                _ => [0.0, 1.0, 0.0, 1.0],
            }
        })
        .collect()
}

pub struct ScreenTiles;

impl Kernel for ScreenTiles {
    fn decl(&self) -> &'static KernelDecl {
        &DECL
    }

    fn case(&self, _shader: &Shader, _ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let (w, h, fill) = [
            (256, 256, 0.3),
            (37, 23, 0.2),
            (64, 64, 0.0),
            (61, 7, 1.0),
            (1, 1, 1.0),
            (1920, 1080, 0.1),
        ][index % 6];
        let n = normals(seed, index, w, h, fill);
        case_for(&n, w, h, format!("#{index} {w}x{h} fill {fill}"), seed)
    }

    fn mirror(&self, case: &Case, data: &Resources, _mode: FloatMode) -> MirrorOutputs {
        let mut io = Io::read(data);
        let [w, h, ..] = io.frame.0.size;
        debug_assert_eq!(case.passes.len(), 1);
        io.tile_list = tile_list(&io.gb_normal, w, h);
        io.outputs()
    }

    fn canonicalise(
        &self,
        resource: &str,
        data: &mut HostBuffer,
        _all: &BTreeMap<String, HostBuffer>,
    ) {
        if resource == "tile_list" {
            let v: &mut [u32] = bytemuck::cast_slice_mut(&mut data.bytes);
            let count = (v[3] as usize).min(v.len() - HEADER);
            v[HEADER..HEADER + count].sort_unstable();
        }
    }
}
