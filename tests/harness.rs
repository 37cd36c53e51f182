//! The harness's own machinery on small inline kernels: 3D textures with mips and padded-row readback,
//! multi-pass runs with an indirect dispatch from a GPU-built work list, and comparison after
//! canonicalising an order the GPU leaves free (atomic allocation).
use crate::common;

use common::gpu;
use std::collections::BTreeMap;
use vxgi::harness::kernel::verify_case;
use vxgi::harness::run::{run, Pass, View, Workgroups};
use vxgi::harness::{
    Case, Check, DispatchRule, FloatMode, HostBuffer, HostResource, HostTexture, Indexing, Kernel,
    KernelDecl, Output, Resources, ScalarKind, Shader, Tolerance,
};

const TEXTURE_WGSL: &str = r#"
@group(0) @binding(0) var src: texture_3d<f32>;
@group(0) @binding(1) var dst: texture_storage_3d<rgba32float, write>;

// Doubles mip 1 of `src` into `dst`.
@compute @workgroup_size(4, 4, 1)
fn double_mip1(@builtin(global_invocation_id) g: vec3<u32>) {
    let dims = textureDimensions(dst);
    if (any(g >= dims)) {
        return;
    }
    textureStore(dst, g, textureLoad(src, g, 1) * 2.0);
}
"#;

#[test]
fn texture_mips_round_trip_and_storage_writes_read_back_without_row_padding() {
    let shader = Shader::from_wgsl("tests/texture.wgsl", TEXTURE_WGSL).unwrap();
    // 10x6x4 rgba32float with 2 mips: mip 1 is 5x3x2, 80-byte rows the copy pads to 256.
    let mut src = HostTexture::zeroed(
        wgpu::TextureFormat::Rgba32Float,
        wgpu::TextureDimension::D3,
        [10, 6, 4],
        2,
    );
    for (m, level) in src.levels.iter_mut().enumerate() {
        let v: Vec<f32> = (0..level.len() / 4)
            .map(|i| (i as f32) * 0.5 + m as f32 * 1000.0)
            .collect();
        level.copy_from_slice(bytemuck::cast_slice(&v));
    }
    let dst = HostTexture::zeroed(
        wgpu::TextureFormat::Rgba32Float,
        wgpu::TextureDimension::D3,
        [5, 3, 2],
        1,
    );
    let mut resources = Resources::new();
    resources.insert("src".into(), HostResource::Texture(src.clone()));
    resources.insert("dst".into(), HostResource::Texture(dst));
    let pass = Pass {
        label: "double".into(),
        entry: "double_mip1".into(),
        bindings: vec![
            ("src".into(), View::Texture("src".into())),
            (
                "dst".into(),
                View::TextureMip {
                    name: "dst".into(),
                    mip: 0,
                },
            ),
        ],
        workgroups: Workgroups::Direct([2, 1, 2]),
    };
    let out = run(
        gpu(),
        &shader,
        "texture test",
        &resources,
        std::slice::from_ref(&pass),
        &["src", "dst"],
    )
    .unwrap();
    assert_eq!(
        out.resources["src"],
        HostResource::Texture(src.clone()),
        "every mip reads back as uploaded"
    );
    let got: &[f32] = bytemuck::cast_slice(&out.resources["dst"].texture().unwrap().levels[0]);
    let want: Vec<f32> = bytemuck::cast_slice::<u8, f32>(&src.levels[1])
        .iter()
        .map(|x| x * 2.0)
        .collect();
    assert_eq!(got, want.as_slice());

    // A storage texture of the wrong format is refused before dispatch, naming the binding.
    let mut bad = resources.clone();
    bad.insert(
        "dst".into(),
        HostResource::Texture(HostTexture::zeroed(
            wgpu::TextureFormat::Rgba16Float,
            wgpu::TextureDimension::D3,
            [5, 3, 2],
            1,
        )),
    );
    let err = run(gpu(), &shader, "texture test", &bad, &[pass], &[]).unwrap_err();
    assert!(
        err.to_string().contains("`dst`") && err.to_string().contains("Rgba32Float"),
        "{err}"
    );
}

const WORKLIST_WGSL: &str = r#"
@group(0) @binding(0) var<storage, read> values: array<u32>;
@group(0) @binding(1) var<storage, read_write> list: array<u32>;
// x, y, z of the indirect dispatch, then the list length.
@group(0) @binding(2) var<storage, read_write> args: array<atomic<u32>, 4>;
@group(0) @binding(3) var<storage, read_write> tripled: array<u32>;
// The same buffer, read-only, for the pass that is dispatched from it (a buffer used for indirect
// arguments cannot be writable storage in the same dispatch).
@group(0) @binding(4) var<storage, read> args_in: array<u32, 4>;

// Work list of the non-zero elements; slots are taken with an atomic, so their order is free.
@compute @workgroup_size(64)
fn build(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= arrayLength(&values) || values[i] == 0u) {
        return;
    }
    let slot = atomicAdd(&args[3], 1u);
    list[slot] = i;
    if (slot % 64u == 0u) {
        atomicAdd(&args[0], 1u);
    }
}

// Dispatched indirectly: one invocation per list entry.
@compute @workgroup_size(64)
fn process(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= args_in[3]) {
        return;
    }
    let i = list[gid.x];
    tripled[i] = values[i] * 3u;
}
"#;

static WORKLIST: KernelDecl = KernelDecl {
    name: "worklist_test",
    wgsl_path: "tests/harness.rs (WORKLIST_WGSL)",
    wgsl: WORKLIST_WGSL,
    includes: &[],
    entry: "build",
    inputs: &["values"],
    outputs: &[
        Output {
            binding: "list",
            tolerance: Tolerance::Exact,
        },
        Output {
            binding: "args",
            tolerance: Tolerance::Exact,
        },
        Output {
            binding: "tripled",
            tolerance: Tolerance::Exact,
        },
    ],
    dispatch: DispatchRule::PerElement { binding: "values" },
    mirror: "tests/harness.rs::Worklist::mirror",
    summary: "harness self-test: GPU-built work list + indirect dispatch",
};

struct Worklist;

impl Kernel for Worklist {
    fn decl(&self) -> &'static KernelDecl {
        &WORKLIST
    }
    fn case(
        &self,
        shader: &Shader,
        ctx: &vxgi::harness::GpuContext,
        seed: u64,
        index: usize,
    ) -> Case {
        let n = 1000 + index * 37;
        let values: Vec<u32> = (0..n as u64)
            .map(|i| {
                if (i * 2_654_435_761 + seed).is_multiple_of(3) {
                    (i % 97) as u32 + 1
                } else {
                    0
                }
            })
            .collect();
        let mut resources = Resources::new();
        resources.insert(
            "values".into(),
            HostResource::Buffer(HostBuffer::u32(&values)),
        );
        resources.insert(
            "list".into(),
            HostResource::Buffer(HostBuffer::zeroed(n * 4, ScalarKind::U32)),
        );
        resources.insert(
            "args".into(),
            HostResource::Buffer(HostBuffer::u32(&[0, 1, 1, 0])),
        );
        resources.insert(
            "tripled".into(),
            HostResource::Buffer(HostBuffer::zeroed(n * 4, ScalarKind::U32)),
        );
        let all = |names: &[&str]| vxgi::harness::run::bind_same_names(names.iter().copied());
        let build = WORKLIST.pass(
            shader,
            ctx,
            "build".into(),
            all(&["values", "list", "args"]),
            n as u64,
        );
        let process = Pass {
            label: "process".into(),
            entry: "process".into(),
            bindings: vec![
                ("values".into(), View::Buffer("values".into())),
                ("list".into(), View::Buffer("list".into())),
                ("args_in".into(), View::Buffer("args".into())),
                ("tripled".into(), View::Buffer("tripled".into())),
            ],
            workgroups: Workgroups::Indirect {
                buffer: "args".into(),
                offset: 0,
            },
        };
        let checks = ["list", "args", "tripled"]
            .iter()
            .map(|r| Check {
                resource: r.to_string(),
                output: WORKLIST
                    .outputs
                    .iter()
                    .find(|o| o.binding == *r)
                    .unwrap()
                    .binding,
                indexing: Indexing::Linear,
            })
            .collect();
        Case {
            label: format!("#{index} n={n}"),
            seed,
            resources,
            passes: vec![build, process],
            checks,
            effective_bytes: 0,
        }
    }
    fn mirror(
        &self,
        _case: &Case,
        data: &Resources,
        _mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        let values = data["values"].buffer().unwrap().as_u32();
        let mut list = vec![0u32; values.len()];
        let mut tripled = vec![0u32; values.len()];
        let mut count = 0;
        for (i, &v) in values.iter().enumerate() {
            if v != 0 {
                list[count] = i as u32;
                tripled[i] = v * 3;
                count += 1;
            }
        }
        let args = [(count as u32).div_ceil(64), 1, 1, count as u32];
        BTreeMap::from([
            ("list".to_string(), HostBuffer::u32(&list)),
            ("args".to_string(), HostBuffer::u32(&args)),
            ("tripled".to_string(), HostBuffer::u32(&tripled)),
        ])
    }
    /// Slots come from an atomic counter: compare the list as a sorted multiset.
    fn canonicalise(
        &self,
        resource: &str,
        data: &mut HostBuffer,
        _all: &BTreeMap<String, HostBuffer>,
    ) {
        if resource == "list" {
            let v: &mut [u32] = bytemuck::cast_slice_mut(&mut data.bytes);
            v.sort_unstable();
        }
    }
}

#[test]
fn indirect_dispatch_from_a_gpu_built_work_list_matches_after_canonicalising() {
    let shader = WORKLIST.shader().unwrap();
    for index in 0..4 {
        let case = Worklist.case(&shader, gpu(), 11, index);
        let (comps, ..) = verify_case(gpu(), &shader, &Worklist, &case, None).unwrap();
        assert_eq!(comps.len(), 3);
        for c in &comps {
            assert!(c.passed(), "{}", c.report());
        }
    }
}

#[test]
fn the_gpu_work_list_is_a_permutation_of_the_mirrors() {
    // The slot order comes from an atomic counter and is the GPU's to choose; only the multiset is
    // defined, which is what `canonicalise` (sorting) compares.
    let shader = WORKLIST.shader().unwrap();
    let case = Worklist.case(&shader, gpu(), 5, 3);
    let out = run(
        gpu(),
        &shader,
        "worklist_test",
        &case.resources,
        &case.passes,
        &["list"],
    )
    .unwrap();
    let mut gpu_list = out.buffer("list").as_u32().to_vec();
    let mut mirror_list = Worklist.mirror(&case, &case.resources, FloatMode::Ieee)["list"]
        .as_u32()
        .to_vec();
    gpu_list.sort_unstable();
    mirror_list.sort_unstable();
    assert_eq!(gpu_list, mirror_list);
}

#[test]
fn an_indirect_argument_buffer_too_small_is_refused() {
    let shader = WORKLIST.shader().unwrap();
    let refused = |case: &vxgi::harness::Case| {
        let passes = &case.passes;
        run(
            gpu(),
            &shader,
            "worklist_test",
            &case.resources,
            passes,
            &[],
        )
        .unwrap_err()
    };
    let mut case = Worklist.case(&shader, gpu(), 1, 0);
    case.passes[1].workgroups = Workgroups::Indirect {
        buffer: "args".into(),
        offset: 8,
    };
    let err = refused(&case);
    assert!(err.to_string().contains("indirect"), "{err}");

    // Dispatching from a buffer the same pass binds as writable storage is refused before dispatch.
    let mut case = Worklist.case(&shader, gpu(), 1, 0);
    case.passes[0].workgroups = Workgroups::Indirect {
        buffer: "args".into(),
        offset: 0,
    };
    let err = refused(&case);
    assert!(
        err.to_string().contains("`args`") && err.to_string().contains("writable"),
        "{err}"
    );
}

#[test]
fn included_helpers_report_their_own_file_and_line() {
    let helper = "// helper\nfn twice(x: f32) -> f32 {\n    return x * 2.0 +;\n}\n";
    let kernel = "@group(0) @binding(0) var<storage, read_write> dst: array<f32>;\n@compute @workgroup_size(1)\nfn main() {\n    dst[0] = twice(1.0);\n}\n";
    let err = Shader::from_parts(&[
        ("kernels/common/helper.wgsl", helper),
        ("kernels/k.wgsl", kernel),
    ])
    .unwrap_err();
    assert!(
        err.to_string().starts_with("kernels/common/helper.wgsl:3:"),
        "{err}"
    );

    let good = "fn twice(x: f32) -> f32 {\n    return x * 2.0;\n}\n";
    let shader = Shader::from_parts(&[
        ("kernels/common/helper.wgsl", good),
        ("kernels/k.wgsl", kernel),
    ])
    .unwrap();
    assert_eq!(
        shader.binding("dst").unwrap().line,
        1,
        "binding lines are lines of the kernel file"
    );
    let bad_kernel = kernel.replace("twice(1.0)", "twice(1u)");
    let err = Shader::from_parts(&[
        ("kernels/common/helper.wgsl", good),
        ("kernels/k.wgsl", &bad_kernel),
    ])
    .unwrap_err();
    assert!(err.to_string().starts_with("kernels/k.wgsl:4:"), "{err}");
}

const ZERO_WGSL: &str = r#"
@group(0) @binding(0) var<storage, read_write> dst: array<f32>;

// Writes 0 everywhere: what a GPU that flushes subnormal results writes for a subnormal value.
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x < arrayLength(&dst)) {
        dst[gid.x] = 0.0;
    }
}
"#;

static ZERO: KernelDecl = KernelDecl {
    name: "flush_test",
    wgsl_path: "tests/harness.rs (ZERO_WGSL)",
    wgsl: ZERO_WGSL,
    includes: &[],
    entry: "main",
    inputs: &[],
    outputs: &[Output {
        binding: "dst",
        tolerance: Tolerance::Exact,
    }],
    dispatch: DispatchRule::PerElement { binding: "dst" },
    mirror: "tests/harness.rs::Flush::mirror",
    summary: "harness self-test: a subnormal result flushed by the GPU",
};

/// A mirror that ignores `FloatMode` and expects `value` in every element.
struct Flush {
    value: f32,
}

impl Kernel for Flush {
    fn decl(&self) -> &'static KernelDecl {
        &ZERO
    }
    fn case(
        &self,
        shader: &Shader,
        ctx: &vxgi::harness::GpuContext,
        seed: u64,
        _index: usize,
    ) -> Case {
        let mut resources = Resources::new();
        resources.insert(
            "dst".into(),
            HostResource::Buffer(HostBuffer::f32(&[1.0; 100])),
        );
        let all = vxgi::harness::run::bind_same_names(["dst"]);
        let pass = ZERO.pass(shader, ctx, "zero".into(), all, 100);
        Case {
            label: format!("value {:e}", self.value),
            seed,
            resources,
            passes: vec![pass],
            checks: vec![Check {
                resource: "dst".into(),
                output: "dst",
                indexing: Indexing::Linear,
            }],
            effective_bytes: 0,
        }
    }
    fn mirror(
        &self,
        _case: &Case,
        _data: &Resources,
        _mode: FloatMode,
    ) -> BTreeMap<String, HostBuffer> {
        BTreeMap::from([("dst".to_string(), HostBuffer::f32(&[self.value; 100]))])
    }
}

#[test]
fn a_gpu_may_flush_a_subnormal_result_even_where_the_mirror_ignores_flush_mode() {
    let shader = ZERO.shader().unwrap();
    // 1.7e-42 is subnormal: WGSL lets the GPU write 0 (an H100 did, in direct_light).
    let flushed = Flush { value: 1.7e-42 };
    let case = flushed.case(&shader, gpu(), 1, 0);
    let (comps, ..) = verify_case(gpu(), &shader, &flushed, &case, None).unwrap();
    assert!(comps[0].passed(), "{}", comps[0].report());
    assert_eq!(comps[0].flushed, 100);
    // The smallest normal is not flushable: the same zeros must fail.
    let normal = Flush {
        value: f32::MIN_POSITIVE,
    };
    let case = normal.case(&shader, gpu(), 1, 0);
    let (comps, ..) = verify_case(gpu(), &shader, &normal, &case, None).unwrap();
    assert!(!comps[0].passed());
    assert_eq!(comps[0].failures, 100);
}

const ADD_ONE_WGSL: &str = r#"
@group(0) @binding(0) var<storage, read> src: array<u32>;
@group(0) @binding(1) var<storage, read_write> dst: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x < arrayLength(&dst)) {
        dst[gid.x] = src[gid.x] + 1u;
    }
}
"#;

const DOUBLE_WGSL: &str = r#"
@group(0) @binding(0) var<storage, read> input: array<u32>;
@group(0) @binding(1) var<storage, read_write> output: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x < arrayLength(&output)) {
        output[gid.x] = input[gid.x] * 2u;
    }
}
"#;

/// Two kernels chained on one set of GPU resources (`prepare_chain`): the second reads what the first
/// wrote, under its own binding names; stages dispatched one by one (`dispatch_steps`) give the same
/// result as all at once, and only the final resource needs a readback. A chain whose stage binds a
/// resource the set lacks is refused before anything runs.
#[test]
fn a_chain_of_kernels_shares_gpu_resources() {
    use vxgi::harness::{prepare_chain, Stage};
    let a = Shader::from_wgsl("add_one.wgsl", ADD_ONE_WGSL).unwrap();
    let b = Shader::from_wgsl("double.wgsl", DOUBLE_WGSL).unwrap();
    let n = 1000u32;
    let mut res = Resources::new();
    res.insert(
        "x".into(),
        HostResource::Buffer(HostBuffer::u32(&(0..n).collect::<Vec<_>>())),
    );
    for name in ["y", "z"] {
        res.insert(
            name.into(),
            HostResource::Buffer(HostBuffer::zeroed(n as usize * 4, ScalarKind::U32)),
        );
    }
    let pass = |bindings: [(&str, &str); 2]| Pass {
        label: "p".into(),
        entry: "main".into(),
        bindings: bindings
            .iter()
            .map(|(w, r)| (w.to_string(), View::Buffer(r.to_string())))
            .collect(),
        workgroups: Workgroups::Direct([n.div_ceil(64), 1, 1]),
    };
    let pa = [pass([("src", "x"), ("dst", "y")])];
    let pb = [pass([("input", "y"), ("output", "z")])];
    let chain = [
        Stage {
            shader: &a,
            kernel: "add_one",
            passes: &pa,
        },
        Stage {
            shader: &b,
            kernel: "double",
            passes: &pb,
        },
    ];
    let prepared = prepare_chain(gpu(), &chain, &res).unwrap();
    assert_eq!(prepared.step_count(), 2);
    prepared.dispatch_steps(0..1).unwrap();
    prepared.dispatch_steps(1..2).unwrap();
    let out = prepared.read(&["z"]).unwrap();
    let z = out["z"].buffer().unwrap().as_u32();
    assert!(z.iter().enumerate().all(|(i, &v)| v == 2 * (i as u32 + 1)));
    // All at once: the same.
    let again = prepare_chain(gpu(), &chain, &res).unwrap();
    again.dispatch().unwrap();
    assert_eq!(
        again.read(&["z"]).unwrap()["z"].buffer().unwrap().as_u32(),
        z
    );
    // A binding to a resource the set lacks: refused.
    let bad = [pass([("input", "nope"), ("output", "z")])];
    let chain = [Stage {
        shader: &b,
        kernel: "double",
        passes: &bad,
    }];
    assert!(prepare_chain(gpu(), &chain, &res).is_err());
}

#[allow(dead_code)] // its main
#[path = "../examples/tdd_own_kernel.rs"]
mod tdd_own_kernel;

/// examples/tdd_own_kernel.rs: a kernel declared outside vxgi (its WGSL beside the example) verifies
/// with the harness on its generated cases; the same kernel with one coefficient wrong in its WGSL
/// fails, and the report names the kernel, the case and the worst elements.
#[test]
fn an_outside_kernel_verifies_and_its_bug_is_reported() {
    use tdd_own_kernel::{Luminance, DECL};
    let opts = vxgi::harness::VerifyOptions {
        cases: 5,
        seed: 3,
        corrupt: None,
    };
    let rep = vxgi::harness::verify(gpu(), &Luminance(&DECL), &opts, &mut |_| {}).unwrap();
    assert!(rep.passed() && rep.elements > 10_000, "{rep:?}");
    let wrong: &'static str = Box::leak(DECL.wgsl.replace("0.7152", "0.7150").into_boxed_str());
    let bad: &'static vxgi::harness::KernelDecl = Box::leak(Box::new(vxgi::harness::KernelDecl {
        wgsl: wrong,
        ..DECL
    }));
    let rep = vxgi::harness::verify(gpu(), &Luminance(bad), &opts, &mut |_| {}).unwrap();
    assert!(!rep.passed());
    let report = rep.failures[0].report();
    assert!(
        report.contains("luminance") && report.contains("luma"),
        "{report}"
    );
}
