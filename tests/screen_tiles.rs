//! GPU vs mirror for `kernels/screen_tiles.wgsl` (the work list of screen tiles holding a surface), and
//! the skip rule it implements: empty tiles are listed nowhere, so the cone passes never dispatch them.
use crate::common::{gpu, passing_run};
use vxgi::kernels::screen_tiles::{case_for, normals, ScreenTiles, DECL};
use vxgi_cpu_mirror::screen_tiles::HEADER;

fn gpu_list(normal: &[[f32; 4]], w: u32, h: u32) -> Vec<u32> {
    let shader = DECL.shader().unwrap();
    let case = case_for(normal, w, h, "direct".into(), 0);
    let out = passing_run(&shader, &ScreenTiles, &case, &["tile_list"]);
    out.buffer("tile_list").as_u32().to_vec()
}

#[test]
fn a_sparse_view_lists_only_its_surface_tiles_and_a_full_one_every_tile() {
    // 64x48: 8x6 tiles. Surface only in the left 10 columns -> tile columns 0 and 1 of every row.
    let (w, h) = (64u32, 48u32);
    let up = [0.0, 1.0, 0.0, 1.0];
    let sparse: Vec<[f32; 4]> = (0..w * h)
        .map(|p| if p % w < 10 { up } else { [0.0; 4] })
        .collect();
    let list = gpu_list(&sparse, w, h);
    assert_eq!(&list[..HEADER], &[12, 1, 1, 12]);
    let mut tiles = list[HEADER..HEADER + 12].to_vec();
    tiles.sort();
    let expect: Vec<u32> = (0..6).flat_map(|r| [8 * r, 8 * r + 1]).collect();
    assert_eq!(tiles, expect);
    let full = vec![up; (w * h) as usize];
    assert_eq!(&gpu_list(&full, w, h)[..HEADER], &[48, 1, 1, 48]);
    // No surface: nothing is dispatched (all arguments 0).
    let empty = gpu_list(&normals(1, 0, w, h, 0.0), w, h);
    assert!(empty.iter().all(|&v| v == 0));
}

/// The Cornell box at 64x64 seen from `eye_z` (3.9: the default view, the box fills the screen).
fn cornell_from(eye_z: f32) -> vxgi::scene::Scene {
    let mut scene = crate::common::cornell(64, 64, 32);
    scene.camera.eye = [0.0, 1.0, eye_z];
    scene
}

#[test]
fn the_cone_pass_skips_empty_tiles_without_changing_the_image() {
    use vxgi::kernels::{cone_trace, screen_tiles};
    let ctx = gpu();
    let cones = cone_trace::ConeSettings::default();
    let listed = cone_trace::scene_case(ctx, &cornell_from(11.0), &cones).unwrap();
    let count = |c: &vxgi::harness::Case| c.resources["tile_list"].buffer().unwrap().as_u32()[3];
    let tiles = count(&listed);
    // The rule fires: the box covers a few of the 64 tiles.
    assert!(tiles > 0 && tiles < 32, "{tiles} of 64 tiles listed");
    // Every tile dispatched (what a plain dispatch runs) gives the same image, bit for bit.
    let every = screen_tiles::every_tile(&listed);
    assert_eq!(count(&every), 64);
    let image = |case| cone_trace::run_case(ctx, &cone_trace::DECL, case).unwrap();
    assert_eq!(image(&listed), image(&every));
}

#[test]
fn vct_dense_frames_report_their_listed_tiles() {
    let ctx = gpu();
    let cones = vxgi::kernels::cone_trace::ConeSettings::default();
    let near = vxgi::render::render(ctx, &cornell_from(3.9), &cones, |_| {}).unwrap();
    assert_eq!(
        near.cone_tiles,
        Some((64, 64)),
        "a closed box fills every tile"
    );
    let far = vxgi::render::render(ctx, &cornell_from(11.0), &cones, |_| {}).unwrap();
    let (listed, all) = far.cone_tiles.unwrap();
    assert_eq!(all, 64);
    assert!(listed > 0 && listed < 32, "{listed} tiles");
    // Nothing the mirror frame (which visits every texel) shades is lost to the GPU-built list: the
    // same number of pixels get AO.
    let mirror = vxgi::render::render_mirror(&cornell_from(11.0), &cones).unwrap();
    let surface = |img: &vxgi::images::RgbImage| {
        img.pixels
            .iter()
            .filter(|p| p.iter().any(|&c| c > 0.0))
            .count()
    };
    assert!(surface(&far.ao) > 0);
    assert_eq!(surface(&far.ao), surface(&mirror.ao));
}

/// Past 65535 listed tiles the indirect grid wraps into y (WebGPU's per-dimension limit): workgroup
/// (x, y) shades tile x + 65535 y of the list. A list of 65536 background tiles then one surface tile
/// makes the cone pass reach that tile only from workgroup (1, 1), cheaply (background invocations
/// return at once); it must shade exactly that tile, as the plain list does.
#[test]
fn more_tiles_than_one_grid_row_reach_the_tiles_past_it() {
    use vxgi::harness::HostBuffer;
    use vxgi::kernels::cone_trace;
    use vxgi_cpu_mirror::screen_tiles::{dispatch_args, MAX_GROUPS};
    let ctx = gpu();
    let cones = cone_trace::ConeSettings::default();
    let listed = cone_trace::scene_case(ctx, &cornell_from(11.0), &cones).unwrap();
    let surface = listed.resources["tile_list"].buffer().unwrap().as_u32()[HEADER];
    let normals: &[[f32; 4]] =
        bytemuck::cast_slice(&listed.resources["gb_normal"].buffer().unwrap().bytes);
    // Tile 0 (top-left corner) is background in this view.
    assert!((0..8).all(|y| (0..8).all(|x| normals[x + 64 * y][3] == 0.0)));
    let count = MAX_GROUPS + 2;
    let mut long = dispatch_args(count).to_vec();
    assert_eq!(long, [MAX_GROUPS, 2, 1]);
    long.push(count);
    long.extend(std::iter::repeat_n(0u32, MAX_GROUPS as usize + 1));
    long.push(surface);
    let mut case = listed.clone();
    case.resources
        .insert("tile_list".into(), HostBuffer::u32(&long).into());
    let [ind, ao] = cone_trace::run_case(ctx, &cone_trace::DECL, &case).unwrap();
    let [ind_all, ao_all] = cone_trace::run_case(ctx, &cone_trace::DECL, &listed).unwrap();
    let px = |b: &[u8]| -> Vec<[f32; 4]> { bytemuck::cast_slice(b).to_vec() };
    let (ind, ao, ind_all, ao_all) = (px(&ind), px(&ao), px(&ind_all), px(&ao_all));
    let (tx, ty) = (surface as usize % 8, surface as usize / 8);
    let mut shaded = 0;
    for p in 0..64 * 64usize {
        let (x, y) = (p % 64, p / 64);
        if x / 8 == tx && y / 8 == ty {
            assert_eq!((ind[p], ao[p]), (ind_all[p], ao_all[p]), "pixel {p}");
            shaded += (ao[p][0] != 0.0) as usize;
        } else {
            assert_eq!(
                (ind[p], ao[p]),
                ([0.0; 4], [0.0; 4]),
                "pixel {p} outside the tile"
            );
        }
    }
    assert!(shaded > 0, "tile {surface} was shaded");
}
