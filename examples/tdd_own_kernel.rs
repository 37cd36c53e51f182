//! Kernel-level TDD for a kernel that is not part of vxgi: its WGSL beside this file
//! (tdd_own_kernel.wgsl), a scalar mirror, a tolerance, generated cases, and the harness's verify.
//! `cargo run --example tdd_own_kernel` (exit 1 with the mismatch report where the GPU disagrees).
use std::collections::BTreeMap;
use vxgi::harness::*;

pub static DECL: KernelDecl = KernelDecl {
    name: "luminance",
    wgsl_path: "examples/tdd_own_kernel.wgsl",
    wgsl: include_str!("tdd_own_kernel.wgsl"),
    includes: &[],
    entry: "main",
    inputs: &["rgb"],
    // Three products and two sums of non-negative terms, each correctly rounded or fused: within
    // 3 ULP; flushing subnormal inputs or products (WGSL allows it) moves the sum by under 1e-37.
    outputs: &[Output {
        binding: "luma",
        tolerance: Tolerance::Ulp {
            ulps: 3,
            abs_floor: 1e-37,
        },
    }],
    dispatch: DispatchRule::PerElement { binding: "luma" },
    mirror: "tdd_own_kernel::luminance",
    summary: "Rec. 709 luminance of linear RGB",
};

/// The mirror: the WGSL's arithmetic in its order.
pub fn luminance(c: &[f32; 4]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// The kernel under test: `DECL`, or another declaration of the same interface (a changed WGSL).
pub struct Luminance(pub &'static KernelDecl);

impl Kernel for Luminance {
    fn decl(&self) -> &'static KernelDecl {
        self.0
    }
    /// Random colours mixed with hard values (zero, the smallest subnormal, huge, exact halves).
    fn case(&self, shader: &Shader, ctx: &GpuContext, seed: u64, index: usize) -> Case {
        let hard = [0.0, f32::from_bits(1), 1.0e30, 0.5, 1.0];
        let mut x = seed ^ (index as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let mut next = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let r = (x >> 40) as usize;
            [hard[r % 5], (r % 100_000) as f32 * 1e-4][!r.is_multiple_of(8) as usize]
        };
        let n = [1, 63, 64, 65, 10_000][index % 5];
        let rgb: Vec<[f32; 4]> = (0..n).map(|_| [next(), next(), next(), 0.0]).collect();
        let input = HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(&rgb)));
        let inputs = Resources::from([("rgb".to_string(), input)]);
        self.0
            .elementwise_case(shader, ctx, n, inputs, format!("{n} pixels"), seed)
            .expect("luma is a runtime-sized array")
    }
    fn mirror(&self, _: &Case, data: &Resources, _: FloatMode) -> BTreeMap<String, HostBuffer> {
        let rgb: &[[f32; 4]] = buffer_as(data, "rgb").expect("rgb");
        let luma: Vec<f32> = rgb.iter().map(luminance).collect();
        BTreeMap::from([("luma".to_string(), HostBuffer::f32(&luma))])
    }
}

#[allow(dead_code)]
fn main() -> anyhow::Result<()> {
    let opts = VerifyOptions {
        cases: 10,
        seed: 1,
        corrupt: None,
    };
    let rep = verify(&GpuContext::new()?, &Luminance(&DECL), &opts, &mut |_| {})?;
    if let Some(f) = rep.failures.first() {
        anyhow::bail!("{}", f.report());
    }
    println!(
        "luminance: {} elements, max {} ULP",
        rep.elements, rep.max_ulp
    );
    Ok(())
}
