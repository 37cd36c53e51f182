//! Kernel-level TDD for a kernel that is not part of vxgi: its WGSL beside this file
//! (tdd_own_kernel.wgsl), a scalar mirror, a tolerance, generated cases, and the harness's verify.
//! `cargo run --example tdd_own_kernel` (exit 1 with the mismatch report where the GPU disagrees).
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
    outputs: &[Output::ulp("luma", 3, 1e-37)],
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
        let mut next = generated_floats(seed ^ index as u64, &[0.0, 1e-45, 1e30, 0.5, 1.0]);
        let n = [1, 63, 64, 65, 10_000][index % 5];
        let rgb: Vec<[f32; 4]> = (0..n).map(|_| [next(), next(), next(), 0.0]).collect();
        let input = HostResource::Buffer(HostBuffer::f32(bytemuck::cast_slice(&rgb)));
        let inputs = Resources::from([("rgb".to_string(), input)]);
        let label = format!("{n} px");
        let case = self.0.elementwise_case(shader, ctx, n, inputs, label, seed);
        case.expect("luma is a runtime-sized array")
    }
    fn mirror(&self, _: &Case, data: &Resources, _: FloatMode) -> MirrorOutputs {
        let rgb: &[[f32; 4]] = buffer_as(data, "rgb").expect("rgb");
        let luma: Vec<f32> = rgb.iter().map(luminance).collect();
        MirrorOutputs::from([("luma".to_string(), HostBuffer::f32(&luma))])
    }
}

fn main() -> anyhow::Result<()> {
    let opts = VerifyOptions::cases(10);
    let rep = verify(&GpuContext::new()?, &Luminance(&DECL), &opts, &mut |_| {})?
        .check()
        .map_err(anyhow::Error::msg)?;
    let (n, ulp) = (rep.elements, rep.max_ulp);
    println!("luminance: {n} elements, max {ulp} ULP");
    Ok(())
}
