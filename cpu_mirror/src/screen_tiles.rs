//! Mirror of `kernels/screen_tiles.wgsl`: the work list of 8x8 screen tiles that hold a surface, and
//! the indirect dispatch arguments of a pass over them (empty tiles are not dispatched).
//!
//! Tiles are row-major over the image (`tiles_x = ceil(width / 8)`); tile `t` covers pixels
//! `(8 (t % tiles_x) + i, 8 (t / tiles_x) + j)`, `i, j < 8`, clipped to the image. A tile is listed when
//! any of its pixels has a G-buffer normal with `w != 0` (the cone pass's background test), tested on the
//! bits: NaN counts as a surface (WGSL lets a comparison with NaN go either way, and nothing the pass
//! might shade may be dropped), -0 as background.
//!
//! The list is one u32 buffer: `[groups_x, groups_y, groups_z, count, tile...]` — the first three words
//! are `dispatch_workgroups_indirect`'s arguments for one 64-invocation workgroup per listed tile
//! (`groups_x = min(count, 65535)`, `groups_y = ceil(count / 65535)`, `groups_z = 1`; all 0 when no tile
//! is listed), `count` the number of tiles, then the tiles. The GPU appends tiles with an atomic counter,
//! so their order is free: this mirror lists them in ascending order and comparisons sort the GPU's.
//! Exact (integers and one comparison with 0 per pixel).

/// Side of a screen tile in pixels (one 64-invocation workgroup).
pub const TILE: u32 = 8;
/// Words before the tiles: the three indirect arguments and the count.
pub const HEADER: usize = 4;
/// WebGPU's default `maxComputeWorkgroupsPerDimension`, the row length of the indirect grid.
pub const MAX_GROUPS: u32 = 65535;

/// Tiles across and down an image of `width` x `height` pixels.
pub fn tiles_xy(width: u32, height: u32) -> (u32, u32) {
    (width.div_ceil(TILE), height.div_ceil(TILE))
}

/// Length in u32 words of the list buffer for an image: header plus every tile.
pub fn list_len(width: u32, height: u32) -> usize {
    let (tx, ty) = tiles_xy(width, height);
    HEADER + (tx * ty) as usize
}

/// Indirect dispatch arguments for `count` tiles.
pub fn dispatch_args(count: u32) -> [u32; 3] {
    if count == 0 {
        [0, 0, 0]
    } else {
        [count.min(MAX_GROUPS), count.div_ceil(MAX_GROUPS), 1]
    }
}

/// The list buffer (see the module comment) for G-buffer normals `normal` (row-major, `width` x
/// `height`), tiles ascending, padded with zeros to [`list_len`].
pub fn tile_list(normal: &[[f32; 4]], width: u32, height: u32) -> Vec<u32> {
    assert_eq!(
        normal.len(),
        (width * height) as usize,
        "one normal per pixel"
    );
    let (tx, ty) = tiles_xy(width, height);
    let mut tiles = Vec::new();
    for t in 0..tx * ty {
        let (x0, y0) = ((t % tx) * TILE, (t / tx) * TILE);
        let surface = (y0..(y0 + TILE).min(height)).any(|y| {
            (x0..(x0 + TILE).min(width))
                .any(|x| normal[(x + y * width) as usize][3].to_bits() & 0x7fff_ffff != 0)
        });
        if surface {
            tiles.push(t);
        }
    }
    let count = tiles.len() as u32;
    let mut list = dispatch_args(count).to_vec();
    list.push(count);
    list.extend(tiles);
    list.resize(list_len(width, height), 0);
    list
}

/// The pixel (row-major index) that invocation `local` (0..64) of indirect workgroup `group` shades, or
/// None past the list's count or outside the image: the cone pass's `tile_pixel`.
pub fn tile_pixel(
    list: &[u32],
    group: [u32; 2],
    local: u32,
    width: u32,
    height: u32,
) -> Option<usize> {
    let k = group[0] as usize + group[1] as usize * MAX_GROUPS as usize;
    if k >= list[3] as usize {
        return None;
    }
    let t = list[HEADER + k];
    let (tx, _) = tiles_xy(width, height);
    let x = (t % tx) * TILE + local % TILE;
    let y = (t / tx) * TILE + local / TILE;
    (x < width && y < height).then_some((x + y * width) as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn normals(width: u32, height: u32, surface: impl Fn(u32, u32) -> bool) -> Vec<[f32; 4]> {
        (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| {
                if surface(x, y) {
                    [0.0, 1.0, 0.0, 1.0]
                } else {
                    [0.0; 4]
                }
            })
            .collect()
    }

    #[test]
    fn empty_image_lists_nothing_and_dispatches_nothing() {
        let list = tile_list(&normals(20, 9, |_, _| false), 20, 9);
        assert_eq!(list.len(), HEADER + 3 * 2);
        assert!(list.iter().all(|&v| v == 0));
    }

    #[test]
    fn full_image_lists_every_tile_including_clipped_edges() {
        let list = tile_list(&normals(20, 9, |_, _| true), 20, 9);
        assert_eq!(&list[..HEADER], &[6, 1, 1, 6]);
        assert_eq!(&list[HEADER..], &[0, 1, 2, 3, 4, 5]);
    }

    #[test]
    fn one_pixel_lists_its_tile_only_and_back_faces_count() {
        // Pixel (17, 8) is in tile (2, 1) = 5; a back face has w < 0 and is still shaded (AO).
        let mut n = normals(20, 9, |_, _| false);
        n[17 + 8 * 20][3] = -1.0;
        let list = tile_list(&n, 20, 9);
        assert_eq!(&list[..5], &[1, 1, 1, 1, 5]);
        // The tile's invocations map to its pixels, clipped to the image.
        assert_eq!(tile_pixel(&list, [0, 0], 1, 20, 9), Some(17 + 8 * 20));
        assert_eq!(tile_pixel(&list, [0, 0], 3, 20, 9), Some(19 + 8 * 20));
        assert_eq!(tile_pixel(&list, [0, 0], 4, 20, 9), None); // x = 20
        assert_eq!(tile_pixel(&list, [0, 0], 8, 20, 9), None); // y = 9
        assert_eq!(tile_pixel(&list, [1, 0], 0, 20, 9), None); // past the count
    }

    #[test]
    fn every_surface_pixel_is_reached_exactly_once() {
        let (w, h) = (37, 23);
        let n = normals(w, h, |x, y| {
            (x < 16 && (x * 7 + y * 3) % 11 == 0) || y == 22
        });
        let list = tile_list(&n, w, h);
        let [gx, gy, _] = [list[0], list[1], list[2]];
        let mut seen = vec![0u32; (w * h) as usize];
        for y in 0..gy {
            for x in 0..gx {
                for l in 0..64 {
                    if let Some(p) = tile_pixel(&list, [x, y], l, w, h) {
                        seen[p] += 1;
                    }
                }
            }
        }
        for (p, v) in n.iter().enumerate() {
            if v[3] != 0.0 {
                assert_eq!(seen[p], 1, "pixel {p}");
            }
            assert!(seen[p] <= 1);
        }
        // Sparse: fewer tiles than the image has.
        assert!(list[3] < (list.len() - HEADER) as u32);
    }

    #[test]
    fn more_tiles_than_one_grid_row_wrap_into_y() {
        assert_eq!(dispatch_args(65535), [65535, 1, 1]);
        assert_eq!(dispatch_args(65536), [65535, 2, 1]);
        let list = {
            let mut l = vec![0u32; HEADER + 70000];
            l[3] = 70000;
            for (k, v) in l[HEADER..].iter_mut().enumerate() {
                *v = k as u32;
            }
            l
        };
        // Workgroup (1, 1) is tile 65536 of a 2048 x 2200 image: tiles_x = 256 -> (0, 256).
        assert_eq!(
            tile_pixel(&list, [1, 1], 0, 2048, 2200),
            Some(256 * 8 * 2048)
        );
    }
}
