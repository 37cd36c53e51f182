// histogram_axes — three axes per tile from its blurred normal histogram (Rehfeld et al. 2014, 3.2):
// pick the highest-rated bin (lowest index on ties), re-weight every bin w = (w + 1) * factor[best][n],
// repeat until three axes. Mirror: cpu_mirror/src/histogram_axes.rs.
//
// reweight[64 a + n] = round(255 (1 - |dir_a . dir_n|^8)) (bin-centre directions; built once on the
// host in f64): the paper's (w + 1)(1 - |n . n_best|^8) in 8-bit fixed point, so two re-weightings of
// counts from tiles up to 64 x 64 (blurred <= 16 * 4096) stay inside u32 and every choice is an exact
// integer comparison. The +1 keeps empty bins eligible, so identical normals everywhere still give
// three distinct, well-defined axes.
// Output axes[t] = (a0, a1, a2, geometry pixels of the tile): bin indices; consumers look the
// directions up in the same bin-centre table. Tiles without geometry report 0 pixels (axes then
// meaningless, all bin 0).

struct AxesParams {
    tiles: u32,
}

@group(0) @binding(0) var<uniform> params: AxesParams;
@group(0) @binding(1) var<storage, read> blurred: array<u32>;
@group(0) @binding(2) var<storage, read> histogram: array<u32>;
@group(0) @binding(3) var<storage, read> reweight: array<u32>;
@group(0) @binding(4) var<storage, read_write> axes: array<vec4<u32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = gid.x + gid.y * groups.x * 64u;
    if (t >= params.tiles) {
        return;
    }
    var w: array<u32, 64>;
    var pixels = 0u;
    for (var n = 0u; n < 64u; n = n + 1u) {
        w[n] = blurred[t * 64u + n];
        pixels = pixels + histogram[t * 64u + n];
    }
    var out = vec4<u32>(0u, 0u, 0u, pixels);
    for (var k = 0u; k < 3u; k = k + 1u) {
        var best = 0u;
        for (var n = 1u; n < 64u; n = n + 1u) {
            if (w[n] > w[best]) {
                best = n;
            }
        }
        out[k] = best;
        if (k < 2u) {
            for (var n = 0u; n < 64u; n = n + 1u) {
                w[n] = (w[n] + 1u) * reweight[best * 64u + n];
            }
        }
    }
    axes[t] = out;
}
