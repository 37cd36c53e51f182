// cone_trace — per G-buffer pixel: AO and diffuse cones plus one glossy cone marched through the
// pre-filtered radiance pyramid (Rehfeld et al. 2014 section 4; Crassin et al. 2011 sections 5-7).
// Mirror: cpu_mirror/src/cone_trace.rs (its module comment is the full definition). The march and the
// pixel entry are in kernels/common/cone_march.wgsl (shared with svo_cone_trace); this file is the volume.
//
// Pyramid: levels of a Morton grid of side 2^L concatenated, level l at (8^(L+1) - 8^(L-l+1)) / 7, each
// voxel (L * alpha, alpha) — voxel_light's output and its surface_coverage_mip levels.
// March: diameter from 3/4 of a level-0 cell, first sample half a step out, step = diameter / 2,
// diameter *= 1 + tan and mip level += log2(1 + tan) per step (no logarithm in the loop), quadrilinear
// sampling (outside the grid = empty), alpha corrected for the step (a' = 1 - (1 - a)^(step / cell)),
// front-to-back accumulation, AO weighted 1 / (1 + lambda t) within ao_range, stop when A >= 1 - 1/256
// or past the grid's diagonal. Option mip_clamp (0 = off): level capped at log2(D / (mip_clamp s0)),
// D = the sample's distance from the origin surface's plane (offset + t cos), step ratio per capped cell.
// Option level_bias (<= 0; 0 = the paper's): level log2(d / s0) + level_bias, step ratio per the cell read.
// Option coverage_correlation c (0 = the paper's): a sample adds the opacity (1 - c)(1 - A) a' +
// c max(0, a' - A) and its radiance (L alpha / alpha) times that (c = 1: A is the densest a' so far).
// Pixel: origin p + ng * offset_voxels * s0; diffuse cones from cone_dirs (tangent space, w = weight);
// indirect = albedo (gb_albedo) * sum w C (+ Ks * C of a glossy cone along the mirror direction, tan = clamp(
// sqrt(2 / (n + 2)), 0.02, 1)); AO = 1 - sum w occ. Back faces: AO only. Background: 0. Dispatched
// indirectly over screen_tiles' list (one workgroup per 8x8 tile holding a surface, `tile_pixel`): the
// pixels of unlisted tiles are never visited and keep the zeroed outputs.
// Outputs per pixel (row-major): indirect (rgb, 0), ao (a, a, a, 0).
// Accuracy: per-element bound (see cone_trace::MAG): 4e-4 of the accumulated magnitudes, plus the
// whole remainder where a stop (opacity, distance, AO range) is within rounding of its threshold.
// The volume (the pyramid bindings and their sampling, the depth-ordered blend) is
// kernels/common/pyramid.wgsl.
